#version 450 core
// Exposure, then the sRGB transfer function (IEC 61966-2-1) to 8 bits.
#include "common_uniforms.glsl"
layout(binding = TEX_INPUT) uniform sampler2D uInput;
layout(location = 0) out vec4 oColor;
vec3 linearToSrgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}
void main() {
    vec3 c = texelFetch(uInput, ivec2(gl_FragCoord.xy), 0).rgb * uView.exposure.x;
    oColor = vec4(linearToSrgb(c), 1.0);
}
