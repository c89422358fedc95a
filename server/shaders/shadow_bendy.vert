#version 450 core
// Deformed shadow map of a BendyLight (paper 000 section 4, "Real-Time on the GPU"): each vertex
// brings its world position and its deformed position, computed once per chain edit by
// bendy_deform.comp; the tessellation stages subdivide where the deformation bends edges.
layout(location = 0) in vec3 aPosition;
layout(std430, binding = 1) readonly buffer Deformed { vec4 deformed[]; };
out vec3 vWorld;
out vec4 vDeformed; // xyz Q', w 1 if mapped
out float vKappa;
void main() {
    vWorld = aPosition;
    vDeformed = deformed[2 * gl_VertexID];
    vKappa = deformed[2 * gl_VertexID + 1].x;
}
