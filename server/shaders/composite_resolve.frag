#version 450 core
// A light's contribution per pixel from its per-sample radiance (LightShading::shade on a deep
// buffer): the relight passes ran once per sample over the sample textures (each sample already
// weighted by its coverage), and this sums each pixel's samples. Shading samples in a loop per
// pixel cost llvmpipe the longest pixel's count of iterations on every lane of a group.
#include "common_uniforms.glsl"
layout(binding = TEX_INPUT) uniform sampler2D uSampleRadiance;
layout(binding = TEX_PIXEL_SAMPLES) uniform usampler2D gPixelSamples;
layout(location = OUT_COLOR) out vec4 oColor;
void main() {
    uvec2 range = texelFetch(gPixelSamples, ivec2(gl_FragCoord.xy), 0).xy;
    vec3 sum = vec3(0.0);
    for (uint s = range.x; s < range.x + range.y; ++s) sum += texelAt(uSampleRadiance, sampleTexel(s)).rgb;
    oColor = vec4(sum, 1.0);
}
