#version 450 core
// Deformed shadow map of a BendyLight (paper 000 section 4, "Real-Time on the GPU"): each vertex
// brings its world position and its deformed position, computed once per chain edit by
// bendy_deform.comp; the tessellation stages subdivide where the deformation bends edges.
#include "common_uniforms.glsl"
layout(location = ATTR_POSITION) in vec3 aPosition;
layout(binding = TEX_DEFORMED) uniform samplerBuffer tDeformed; // (as bendy_classify.comp)
out vec3 vWorld;
out vec4 vDeformed; // xyz Q', w 1 if mapped
out vec4 vBend; // bendy_deform.comp's second texel: kappa_eff, segment, rho / R
void main() {
    vWorld = aPosition;
    vDeformed = texelFetch(tDeformed, 2 * gl_VertexID);
    vBend = texelFetch(tDeformed, 2 * gl_VertexID + 1);
}
