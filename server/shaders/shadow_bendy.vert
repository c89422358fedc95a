#version 450 core
// Deformed shadow map of a BendyLight (paper 000 section 4, "Real-Time on the GPU"): vertices
// pass through in world space; the tessellation stages subdivide and deform them.
layout(location = 0) in vec3 aPosition;
out vec3 vWorld;
void main() { vWorld = aPosition; }
