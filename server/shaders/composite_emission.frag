#version 450 core
// Starts the accumulation with the surfaces' own emission (independent of every light),
// coverage-weighted over the pixel's samples.
#include "common_uniforms.glsl"
layout(binding = TEX_GBUFFER_EMISSION) uniform sampler2D gEmission;
layout(binding = TEX_GBUFFER_P) uniform sampler2D gP;
layout(binding = TEX_PIXEL_SAMPLES) uniform usampler2D gPixelSamples;
layout(location = OUT_COLOR) out vec4 oColor;
void main() {
#ifdef DFB_FLAT_SAMPLES
    ivec2 t = ivec2(gl_FragCoord.xy);
    oColor = vec4(texelAt(gEmission, t).rgb * texelAt(gP, t).w, 1.0);
    return;
#endif
    uvec2 range = texelFetch(gPixelSamples, ivec2(gl_FragCoord.xy), 0).xy;
    vec3 sum = vec3(0.0);
    for (uint s = range.x; s < range.x + range.y; ++s) {
        ivec2 t = sampleTexel(s);
        sum += texelAt(gEmission, t).rgb * texelAt(gP, t).w;
    }
    oColor = vec4(sum, 1.0);
}
