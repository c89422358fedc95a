#version 450 core
// One spot light's contribution per pixel from the G-buffer samples (DESIGN section 6;
// docs/lighting.md): every sample of the pixel is shaded and the results averaged with their
// coverages. Radiance = f(l, v) * cos * I / d^2 * spot(cone) * visibility, with I in candela
// (KHR_lights_punctual, with the smooth cone falloff of its reference implementation).
#include "common_uniforms.glsl"
#include "common_brdf.glsl"

layout(binding = TEX_GBUFFER_P) uniform sampler2D gP;
layout(binding = TEX_GBUFFER_N) uniform sampler2D gN;
layout(binding = TEX_GBUFFER_NG) uniform sampler2D gNg;
layout(binding = TEX_GBUFFER_ALBEDO) uniform sampler2D gAlbedo;
layout(binding = TEX_GBUFFER_BRDF) uniform sampler2D gBrdf;
layout(binding = TEX_GBUFFER_SHEEN) uniform sampler2D gSheen;
layout(binding = TEX_GBUFFER_COAT) uniform sampler2D gCoat;
layout(binding = TEX_PIXEL_SAMPLES) uniform usampler2D gPixelSamples;
layout(binding = TEX_SHADOW_MAP) uniform sampler2DShadow shadowMap;

layout(location = 0) out vec4 oColor;
// 0: the light's radiance. 1: its shadow mask: r = coverage-weighted visibility of the samples the
// light reaches (inside the cone, facing it), g = their coverage.
layout(location = 0) uniform int uOutput;
layout(location = 1) uniform int uLinked;
layout(binding = TEX_GBUFFER_ID) uniform usampler2D gId;

// 3x3 percentage-closer filter on top of the hardware 2x2 comparison.
float shadowVisibility(vec3 P, vec3 Ng, float dist) {
    vec3 biased = P + Ng * (uLight.lightCone.w * dist);
    vec4 clip = uLight.worldToLightClip * vec4(biased, 1.0);
    if (clip.w <= 0.0) return 0.0;
    vec3 ndc = clip.xyz / clip.w;
    vec2 uv = ndc.xy * 0.5 + 0.5;
    float ref = ndc.z * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) return 1.0;
    float texel = uLight.lightShadow.x;
    float sum = 0.0;
    for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x) sum += texture(shadowMap, vec3(uv + vec2(x, y) * texel, ref));
    return sum / 9.0;
}

vec3 shadeSample(uint s) {
    ivec2 t = sampleTexel(s);
    vec4 pA = texelFetch(gP, t, 0);
    if (pA.w <= 0.0) return vec3(0.0);
    if (uLinked != 0 && !objectLinked(texelFetch(gId, t, 0).x)) return vec3(0.0); // light linking
    vec3 P = pA.xyz;
    vec3 N = normalize(texelFetch(gN, t, 0).xyz);
    vec3 L;
    float dist2, dist, spot;
    if (uLight.lightPosition.w == 0.0) {
        // Directional (KHR_lights_punctual): parallel light, intensity in lux, no falloff.
        L = -uLight.lightAxis.xyz;
        dist2 = 1.0;
        dist = 1.0;
        spot = 1.0;
    } else {
        vec3 toLight = uLight.lightPosition.xyz - P;
        dist2 = max(dot(toLight, toLight), 1e-12);
        dist = sqrt(dist2);
        L = toLight / dist;
        // Cone falloff: smooth between the outer and inner cosines.
        spot = smoothstep(uLight.lightCone.x, uLight.lightCone.y, dot(-L, uLight.lightAxis.xyz));
    }
    if (spot <= 0.0 || dot(N, L) <= 0.0) return vec3(0.0);
    float vis = 1.0;
    if (uLight.lightCone.z > 0.5) {
        vis = shadowVisibility(P, normalize(texelFetch(gNg, t, 0).xyz), dist);
        if (vis <= 0.0 && uOutput == 0) return vec3(0.0);
    }
    if (uOutput == 1) return vec3(vis * pA.w, pA.w, 0.0);
    vec3 f = evaluateLayeredBrdfCos(N, L, viewVector(P), texelFetch(gAlbedo, t, 0).rgb, texelFetch(gBrdf, t, 0),
                                    texelFetch(gSheen, t, 0), texelFetch(gCoat, t, 0).xy);
    return f * uLight.lightRadiance.rgb * (spot * vis / dist2) * pA.w;
}

void main() {
#ifdef DFB_FLAT_SAMPLES
    // Flat buffer: one sample per pixel, stored at the pixel itself (no indirection, no loop).
    oColor = vec4(shadeSample(uint(gl_FragCoord.y) * uint(uView.sampleLayout.x) + uint(gl_FragCoord.x)), 1.0);
#else
    uvec2 range = texelFetch(gPixelSamples, ivec2(gl_FragCoord.xy), 0).xy;
    vec3 sum = vec3(0.0);
    for (uint s = range.x; s < range.x + range.y; ++s) sum += shadeSample(s);
    oColor = vec4(sum, 1.0);
#endif
}
