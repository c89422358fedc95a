#version 450 core
// Depth only; fragments of triangles with an unmapped vertex never occlude.
in float teValid;
void main() {
    if (teValid < 0.9999) discard;
}
