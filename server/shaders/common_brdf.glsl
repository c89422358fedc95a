// BRDF lobes evaluated from the G-buffer terms (docs/lighting.md). glTF 2.0 metallic-roughness
// (glTF spec, Appendix B): Lambert diffuse + GGX specular with height-correlated Smith
// visibility and Schlick Fresnel; paper 004 section 4.2 factors the BRDF into such lobes.

const float PI = 3.14159265358979;

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

vec3 fresnelSchlick(vec3 f0, float VdotH) {
    return f0 + (vec3(1.0) - f0) * pow(1.0 - VdotH, 5.0);
}

// Reflected radiance factor f(l, v) * NdotL for unit vectors N (normal), L (to light), V (to eye).
// specular in [0,1] scales the dielectric F0: F0 = 0.08 * specular (0.5 -> 0.04, glTF default).
vec3 evaluateBrdfCos(vec3 N, vec3 L, vec3 V, vec3 albedo, float metallic, float roughness, float specular) {
    float NdotL = dot(N, L);
    if (NdotL <= 0.0) return vec3(0.0);
    float NdotV = max(dot(N, V), 1e-4);
    vec3 H = normalize(L + V);
    float NdotH = max(dot(N, H), 0.0);
    float VdotH = max(dot(V, H), 0.0);
    float alpha = max(roughness * roughness, 1e-3);
    vec3 f0 = mix(vec3(0.08 * specular), albedo, metallic);
    vec3 F = fresnelSchlick(f0, VdotH);
    vec3 diffuse = (vec3(1.0) - F) * (1.0 - metallic) * albedo / PI;
    vec3 spec = F * distributionGGX(NdotH, alpha) * visibilitySmithGGX(NdotL, NdotV, alpha);
    return (diffuse + spec) * NdotL;
}
