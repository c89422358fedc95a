// BRDF lobes evaluated from the G-buffer terms (docs/lighting.md). glTF 2.0 metallic-roughness
// (glTF spec, Appendix B): Lambert diffuse + GGX specular with height-correlated Smith
// visibility and Schlick Fresnel; paper 004 section 4.2 factors the BRDF into such lobes.

const float PI = 3.14159265358979;

// Lobes a G-buffer without any sheen or clear coat can leave out (see "Specialisation" in
// common_uniforms.glsl).
#ifndef SHADE_SHEEN
#define SHADE_SHEEN true
#endif
#ifndef SHADE_COAT
#define SHADE_COAT true
#endif

// GGX normal distribution, alpha = roughness^2 (glTF Appendix B.3.2).
float distributionGGX(float NdotH, float alpha) {
    float a2 = alpha * alpha;
    float d = NdotH * NdotH * (a2 - 1.0) + 1.0;
    return a2 / (PI * d * d);
}

// Height-correlated Smith visibility V = G / (4 NdotL NdotV) (glTF Appendix B.3.2).
float visibilitySmithGGX(float NdotL, float NdotV, float alpha) {
    float a2 = alpha * alpha;
    float gv = NdotL * sqrt(NdotV * NdotV * (1.0 - a2) + a2);
    float gl = NdotV * sqrt(NdotL * NdotL * (1.0 - a2) + a2);
    float s = gv + gl;
    return s > 0.0 ? 0.5 / s : 0.0;
}

// Schlick's Fresnel with KHR_materials_specular's F90 (glTF Appendix B.3.3).
vec3 fresnelSchlick(vec3 f0, float f90, float VdotH) {
    return f0 + (vec3(f90) - f0) * pow(1.0 - VdotH, 5.0);
}

// Reflected radiance factor f(l, v) * NdotL for unit vectors N (normal), L (to light), V (to eye):
// glTF Appendix B.3.5's mix(dielectric_brdf, metal_brdf, metallic) with KHR_materials_specular's
// dielectric Fresnel, F0 = 0.08 * specular and F90 = min(2 * specular, 1) for the G-buffer's
// specular level (0.5 = glTF's default F0 0.04; 0 = pure Lambert). Brdf.h evaluateBaseLobes.
vec3 evaluateBrdfCos(vec3 N, vec3 L, vec3 V, vec3 albedo, float metallic, float roughness, float specular) {
    float NdotL = dot(N, L);
    if (NdotL <= 0.0) return vec3(0.0);
    float NdotV = max(dot(N, V), 1e-4);
    vec3 H = normalize(L + V);
    float NdotH = max(dot(N, H), 0.0);
    // Clamped to 1 as well: for L == V (a light at the eye) rounding can make dot(V, H) exceed 1,
    // and pow(x, 5.0) is undefined for x < 0 (NaN on llvmpipe; lightmath_parity_test).
    float VdotH = clamp(dot(V, H), 0.0, 1.0);
    float alpha = max(roughness * roughness, 1e-3);
    vec3 Fd = fresnelSchlick(vec3(0.08 * specular), min(2.0 * specular, 1.0), VdotH);
    vec3 Fm = fresnelSchlick(albedo, 1.0, VdotH);
    float maxFd = max(Fd.x, max(Fd.y, Fd.z));
    vec3 diffuse = ((1.0 - metallic) * (1.0 - maxFd)) * (albedo / PI);
    vec3 spec = mix(Fd, Fm, metallic) * (distributionGGX(NdotH, alpha) * visibilitySmithGGX(NdotL, NdotV, alpha));
    return (diffuse + spec) * NdotL;
}

// Sheen lobe (KHR_materials_sheen): Charlie distribution (Estevez and Kulla 2017) with Neubelt's
// visibility, alpha = sheenRoughness^2.
float distributionCharlie(float NdotH, float alpha) {
    float invA = 1.0 / max(alpha, 1e-3);
    float sin2 = max(1.0 - NdotH * NdotH, 0.0);
    return (2.0 + invA) * pow(sin2, 0.5 * invA) / (2.0 * PI);
}
float visibilityNeubelt(float NdotL, float NdotV) {
    return clamp(1.0 / (4.0 * (NdotL + NdotV - NdotL * NdotV)), 0.0, 1.0);
}

// The full layered BRDF times cos (glTF spec Appendix B and the sheen and clearcoat extensions;
// mirrored by server/include/dfb/lightmath/Brdf.h, which lists where this differs from them):
//   f = coat(F_c) + (1 - coat * F_c) * (sheen + (1 - sheenAlbedoScaling) * base)
// with the sheen albedo scaling approximated by max(sheenColor) (KHR_materials_sheen's
// simplest energy-conservation form) and the clear coat a GGX lobe with F0 = 0.04 and the
// extension's Fresnel of N.V over the shading normal N (the G-buffer has no clear-coat normal).
vec3 evaluateLayeredBrdfCos(vec3 N, vec3 L, vec3 V, vec3 albedo, vec4 brdf, vec4 sheen, vec2 coat) {
    float NdotL = dot(N, L);
    if (NdotL <= 0.0) return vec3(0.0);
    vec3 base = evaluateBrdfCos(N, L, V, albedo, brdf.x, brdf.y, brdf.z);
    float NdotV = max(dot(N, V), 1e-4);
    vec3 H = normalize(L + V);
    float NdotH = max(dot(N, H), 0.0);
    if (SHADE_SHEEN && any(greaterThan(sheen.rgb, vec3(0.0)))) {
        float sheenAlpha = max(sheen.a * sheen.a, 1e-3);
        vec3 fs = sheen.rgb * distributionCharlie(NdotH, sheenAlpha) * visibilityNeubelt(NdotL, NdotV);
        float scaling = 1.0 - max(max(sheen.r, sheen.g), sheen.b);
        base = base * scaling + fs * NdotL;
    }
    if (SHADE_COAT && coat.x > 0.0) {
        float alpha = max(coat.y * coat.y, 1e-3);
        // KHR_materials_clearcoat's fresnel_coat: the Fresnel of the view angle N.V.
        float Fc = 0.04 + 0.96 * pow(1.0 - clamp(NdotV, 0.0, 1.0), 5.0);
        float fc = Fc * distributionGGX(NdotH, alpha) * visibilitySmithGGX(NdotL, NdotV, alpha);
        base = base * (1.0 - coat.x * Fc) + vec3(coat.x * fc * NdotL);
    }
    return base;
}
