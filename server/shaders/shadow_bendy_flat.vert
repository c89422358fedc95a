#version 450 core
// Deformed shadow map, triangles that need no subdivision: their deformed vertices
// (bendy_deform.comp) projected with the undeformed spotlight's perspective.
#include "common_uniforms.glsl"
layout(std430, binding = 1) readonly buffer Deformed { vec4 deformed[]; };
out float teValid;
void main() {
    vec4 d = deformed[2 * gl_VertexID];
    teValid = d.w;
    gl_Position = uLight.worldToLightClip * vec4(d.xyz, 1.0);
}
