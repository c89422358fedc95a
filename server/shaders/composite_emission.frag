#version 450 core
// Starts the accumulation with the surfaces' own emission (independent of every light).
#include "common_uniforms.glsl"
layout(binding = TEX_GBUFFER_EMISSION) uniform sampler2D gEmission;
layout(binding = TEX_GBUFFER_P) uniform sampler2D gP;
layout(location = 0) out vec4 oColor;
void main() {
    ivec2 pix = ivec2(gl_FragCoord.xy);
    oColor = vec4(texelFetch(gEmission, pix, 0).rgb * texelFetch(gP, pix, 0).w, 1.0);
}
