#version 450 core
// Deformed shadow map, triangles that need no subdivision: their deformed vertices
// (bendy_deform.comp) projected with the undeformed spotlight's perspective, all mapped
// (bendy_classify.comp); drawn with shadow_depth.frag.
#include "common_uniforms.glsl"
layout(binding = TEX_DEFORMED) uniform samplerBuffer tDeformed; // (as bendy_classify.comp)
void main() {
    vec4 d = texelFetch(tDeformed, 2 * gl_VertexID);
    gl_Position = uLight.worldToLightClip * vec4(d.xyz, 1.0);
}
