#version 450 core
// Adds one cached contribution into the accumulation target (additive blending is enabled).
#include "common_uniforms.glsl"
layout(binding = TEX_INPUT) uniform sampler2D uInput;
layout(location = 0) out vec4 oColor;
void main() { oColor = vec4(texelFetch(uInput, ivec2(gl_FragCoord.xy), 0).rgb, 0.0); }
