#version 450 core
// Deformed shadow map, triangles that need no subdivision: their deformed vertices
// (bendy_deform.comp) projected with the undeformed spotlight's perspective.
#include "common_uniforms.glsl"
layout(binding = TEX_DEFORMED) uniform samplerBuffer tDeformed; // (as bendy_classify.comp)
out float teValid;
void main() {
    vec4 d = texelFetch(tDeformed, 2 * gl_VertexID);
    teValid = d.w;
    gl_Position = uLight.worldToLightClip * vec4(d.xyz, 1.0);
}
