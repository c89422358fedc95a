#version 450 core
// One spot light's contribution, per pixel, from the G-buffer (DESIGN section 6; docs/lighting.md).
// Radiance = f(l, v) * cos * I / d^2 * spot(cone) * visibility, with I in candela
// (KHR_lights_punctual: the smooth cone falloff of its reference implementation).
#include "common_uniforms.glsl"
#include "common_brdf.glsl"

layout(binding = TEX_GBUFFER_P) uniform sampler2D gP;
layout(binding = TEX_GBUFFER_N) uniform sampler2D gN;
layout(binding = TEX_GBUFFER_NG) uniform sampler2D gNg;
layout(binding = TEX_GBUFFER_ALBEDO) uniform sampler2D gAlbedo;
layout(binding = TEX_GBUFFER_BRDF) uniform sampler2D gBrdf;
layout(binding = TEX_SHADOW_MAP) uniform sampler2DShadow shadowMap;

layout(location = 0) out vec4 oColor;

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

void main() {
    ivec2 pix = ivec2(gl_FragCoord.xy);
    vec4 pA = texelFetch(gP, pix, 0);
    if (pA.w <= 0.0) { oColor = vec4(0.0); return; }
    vec3 P = pA.xyz;
    vec3 N = normalize(texelFetch(gN, pix, 0).xyz);
    vec3 Ng = normalize(texelFetch(gNg, pix, 0).xyz);
    vec3 toLight = uLight.lightPosition.xyz - P;
    float dist2 = max(dot(toLight, toLight), 1e-8);
    float dist = sqrt(dist2);
    vec3 L = toLight / dist;
    // Cone falloff: smooth between the outer and inner cosines.
    float cd = dot(-L, uLight.lightAxis.xyz);
    float spot = smoothstep(uLight.lightCone.x, uLight.lightCone.y, cd);
    if (spot <= 0.0 || dot(N, L) <= 0.0) { oColor = vec4(0.0); return; }
    float vis = uLight.lightCone.z > 0.5 ? shadowVisibility(P, Ng, dist) : 1.0;
    if (vis <= 0.0) { oColor = vec4(0.0); return; }
    vec4 brdf = texelFetch(gBrdf, pix, 0);
    vec3 albedo = texelFetch(gAlbedo, pix, 0).rgb;
    vec3 V = normalize(uView.cameraPosition.xyz - P);
    vec3 f = evaluateBrdfCos(N, L, V, albedo, brdf.x, brdf.y, brdf.z);
    oColor = vec4(f * uLight.lightRadiance.rgb * (spot * vis / dist2) * pA.w, 1.0);
}
