#pragma once
// The BRDF lobes the relight shaders evaluate per G-buffer sample, written once as allocation-free
// C++ for float and double with GLSL names; server/shaders/common_brdf.glsl is the GLSL mirror and
// must compute the same numbers (tests/gpu/lightmath_parity_test.cpp). docs/lighting.md, "BRDF",
// states the formulas; tests/unit/lightmath_brdf_test.cpp checks them against closed forms and
// numeric integrals (normalisation, white furnace, reciprocity).
//
// Sources:
// - Khronos glTF 2.0 Specification (2021), Appendix B "BRDF Implementation": B.3.2 specular BRDF
//   (Trowbridge-Reitz/GGX D with alpha = roughness^2; height-correlated Smith visibility
//   V = G / (4 |N.L| |N.V|), Heitz, "Understanding the Masking-Shadowing Function in
//   Microfacet-Based BRDFs", 2014), B.3.3 Fresnel (Schlick, "An Inexpensive BRDF Model for
//   Physically-based Rendering", 1994), B.3.5 metal/dielectric (fresnel_mix, conductor_fresnel).
// - KHR_materials_sheen (Khronos, 2020): Charlie distribution (Conty Estevez and Kulla,
//   "Production Friendly Microfacet Sheen BRDF", 2017), the simpler visibility of Ashikhmin and
//   Premoze ("Distribution-based BRDFs", 2007; Neubelt and Pettineo, "Crafting a Next-Gen Material
//   Pipeline for The Order: 1886", 2013), albedo scaling.
// - KHR_materials_clearcoat (Khronos, 2020): fresnel_coat layering with IOR 1.5 (F0 = 0.04).
//
// Where the product (the GLSL) differs from those texts, the function says so under "Differs";
// docs/lighting.md lists the same differences.
//
// Conventions: N, L, V are unit vectors, world space; L points to the light, V to the eye. Every
// *Cos function returns f(L, V) * (N.L), i.e. what multiplies the incident irradiance-per-cosine
// (radiance, or I / d^2 for a punctual light); 0 where N.L <= 0.

#include <dfb/lightmath/Scalar.h>

#include <glm/glm.hpp>

#include <algorithm>
#include <cmath>

namespace dfb::lightmath {

/// The GLSL's constant (common_brdf.glsl `PI`, 15 digits), so float results round alike.
constexpr double PI = 3.14159265358979;

/// Smallest GGX/Charlie alpha the shaders use: roughness 0 would make D a Dirac delta (and divide
/// by zero); 1e-3 is about roughness 0.03, below what an 8-bit roughness texture resolves.
constexpr double MIN_ALPHA = 1e-3;
/// N.V is clamped to this: a G-buffer's shading normal may face slightly away from the eye
/// (interpolated or normal-mapped normals); the visibility term must stay finite.
constexpr double MIN_NDOTV = 1e-4;

/// Trowbridge-Reitz / GGX normal distribution (glTF 2.0 Appendix B.3.2; Walter et al.,
/// "Microfacet Models for Refraction through Rough Surfaces", 2007, eq. 33):
/// D = alpha^2 / (pi ((N.H)^2 (alpha^2 - 1) + 1)^2), alpha = roughness^2.
/// Normalised over projected microfacet area: integral of D(h) (N.h) dw_h over the hemisphere = 1.
/// Differs: the spec multiplies by the Heaviside chi+(N.H); callers pass N.H >= 0.
template <typename T> T distributionGGX(T NdotH, T alpha) {
    const T a2 = alpha * alpha;
    const T d = NdotH * NdotH * (a2 - T(1)) + T(1);
    return a2 / (T(PI) * d * d);
}

/// Height-correlated Smith visibility V = G2 / (4 |N.L| |N.V|) (glTF 2.0 Appendix B.3.2):
/// V = 0.5 / (N.L sqrt((N.V)^2 (1 - a^2) + a^2) + N.V sqrt((N.L)^2 (1 - a^2) + a^2)); 0 when both
/// cosines are 0.
/// Differs: the spec's Heaviside terms chi+(H.L), chi+(H.V) are left out; H = normalize(L + V)
/// always has H.L = H.V >= 0.
template <typename T> T visibilitySmithGGX(T NdotL, T NdotV, T alpha) {
    const T a2 = alpha * alpha;
    const T gv = NdotL * std::sqrt(NdotV * NdotV * (T(1) - a2) + a2);
    const T gl = NdotV * std::sqrt(NdotL * NdotL * (T(1) - a2) + a2);
    const T s = gv + gl;
    return s > T(0) ? T(0.5) / s : T(0);
}

/// Schlick's Fresnel (glTF 2.0 Appendix B.3.3, "fresnel_mix"/"conductor_fresnel" with
/// KHR_materials_specular's dielectric_f90): F = F0 + (F90 - F0)(1 - V.H)^5.
/// V.H must lie in [0, 1] (see halfVector).
template <typename T> vec3<T> fresnelSchlick(const vec3<T>& f0, T f90, T VdotH) {
    return f0 + (vec3<T>(f90) - f0) * std::pow(T(1) - VdotH, T(5));
}

/// Lambert's diffuse BRDF (glTF 2.0 Appendix B.3.4, diffuse_brdf): albedo / pi, whose cosine-
/// weighted integral over the hemisphere is the albedo.
template <typename T> vec3<T> lambert(const vec3<T>& albedo) { return albedo / T(PI); }

/// The dielectric Fresnel's ends for the G-buffer's specular level s (docs/gbuffer-format.md,
/// `brdf.specular`): KHR_materials_specular's dielectric_f0 = min(0.04 specularColor, 1) specular
/// and dielectric_f90 = specular, from the one scalar format v2 stores,
/// s = 0.5 specular mean(specularColor): F0 = 0.08 s and F90 = min(2 s, 1). Exact when the
/// specular colour is white (s <= 0.5: specular = 2 s) or the specular weight is 1 (s > 0.5:
/// a colour above white); otherwise F90 is the one a white colour would give.
template <typename T> struct DielectricFresnel {
    T f0, f90;
};
template <typename T> DielectricFresnel<T> dielectricFresnel(T specularLevel) {
    return {T(0.08) * specularLevel, std::min(T(2) * specularLevel, T(1))};
}

/// The two lobes of the metallic-roughness base layer, f (not times N.L), for N.L > 0.
template <typename T> struct BaseLobes {
    vec3<T> diffuse;  ///< (1 - metallic)(1 - max F_dielectric) albedo / pi
    vec3<T> specular; ///< mix(F_dielectric, F_metal, metallic) D V
};

/// The half vector's cosines as the GLSL computes them. V.H is clamped to [0, 1]: for L == V
/// rounding can make dot(V, normalize(L + V)) exceed 1, and GLSL's pow(x, 5.0) is undefined
/// (NaN on llvmpipe) for x < 0.
template <typename T> struct HalfVector {
    T NdotH, VdotH;
};
template <typename T> HalfVector<T> halfVector(const vec3<T>& N, const vec3<T>& L, const vec3<T>& V) {
    const vec3<T> H = glm::normalize(L + V);
    return {std::max(glm::dot(N, H), T(0)), saturate(glm::dot(V, H))};
}

/// glTF 2.0 metallic-roughness base layer exactly as Appendix B.3.5 mixes it, with
/// KHR_materials_specular's dielectric Fresnel ("Implementation"):
///   dielectric_brdf = F_d D V + (1 - max3(F_d)) albedo / pi,  F_d = Schlick(F0_d, F90_d, V.H)
///   metal_brdf      = F_m D V,                                F_m = Schlick(albedo, 1, V.H)
///   f = mix(dielectric_brdf, metal_brdf, metallic),  alpha = max(roughness^2, MIN_ALPHA)
/// with (F0_d, F90_d) from the specular level (dielectricFresnel). Specular 0 is pure Lambert.
/// Not energy conserving at grazing views: see docs/lighting.md, "BRDF" (the spec's fresnel_mix
/// weights the diffuse by 1 - F(V.H) per light direction, not by the specular lobe's albedo).
template <typename T>
BaseLobes<T> evaluateBaseLobes(const vec3<T>& N, const vec3<T>& L, const vec3<T>& V, const vec3<T>& albedo,
                               T metallic, T roughness, T specular) {
    const T NdotL = glm::dot(N, L);
    const T NdotV = std::max(glm::dot(N, V), T(MIN_NDOTV));
    const HalfVector<T> h = halfVector(N, L, V);
    const T alpha = std::max(roughness * roughness, T(MIN_ALPHA));
    const DielectricFresnel<T> d = dielectricFresnel(specular);
    const vec3<T> Fd = fresnelSchlick(vec3<T>(d.f0), d.f90, h.VdotH);
    const vec3<T> Fm = fresnelSchlick(albedo, T(1), h.VdotH);
    const T maxFd = std::max(std::max(Fd.x, Fd.y), Fd.z);
    BaseLobes<T> b;
    b.diffuse = ((T(1) - metallic) * (T(1) - maxFd)) * lambert(albedo);
    b.specular = glm::mix(Fd, Fm, metallic) * (distributionGGX(h.NdotH, alpha) * visibilitySmithGGX(NdotL, NdotV, alpha));
    return b;
}

/// The base layer times N.L: common_brdf.glsl `evaluateBrdfCos`.
template <typename T>
vec3<T> evaluateBrdfCos(const vec3<T>& N, const vec3<T>& L, const vec3<T>& V, const vec3<T>& albedo, T metallic,
                        T roughness, T specular) {
    const T NdotL = glm::dot(N, L);
    if (NdotL <= T(0)) return vec3<T>(T(0));
    const BaseLobes<T> b = evaluateBaseLobes(N, L, V, albedo, metallic, roughness, specular);
    return (b.diffuse + b.specular) * NdotL;
}

/// Charlie sheen distribution (KHR_materials_sheen, "Sheen distribution"; Conty Estevez and Kulla
/// 2017, eq. 2): D = (2 + 1/alpha) sin(theta_h)^(1/alpha) / (2 pi), written with
/// sin^2 = 1 - (N.H)^2; alpha clamped to MIN_ALPHA.
template <typename T> T distributionCharlie(T NdotH, T alpha) {
    const T invA = T(1) / std::max(alpha, T(MIN_ALPHA));
    const T sin2 = std::max(T(1) - NdotH * NdotH, T(0));
    return (T(2) + invA) * std::pow(sin2, T(0.5) * invA) / (T(2) * T(PI));
}

/// The sheen visibility the shaders use: KHR_materials_sheen's "simpler visibility term"
/// (Ashikhmin and Premoze 2007; Neubelt and Pettineo 2013), V = 1 / (4 (N.L + N.V - N.L N.V)),
/// clamped to [0, 1].
/// Differs: the extension's first choice is the "Charlie" visibility (lambda curve fit,
/// visibilitySheenCharlie below); it notes this simpler one is not energy conserving with the
/// albedo-scaling technique. The clamp to 1 only acts where N.L + N.V < 1/4 roughly.
template <typename T> T visibilityNeubelt(T NdotL, T NdotV) {
    return saturate(T(1) / (T(4) * (NdotL + NdotV - NdotL * NdotV)));
}

/// Reference only (no GLSL mirror): the extension's "Charlie" sheen visibility,
/// 1 / ((1 + Lambda(N.V) + Lambda(N.L)) 4 N.V N.L), with the curve fit of Conty Estevez and Kulla
/// 2017 (section 3, Table 1) as KHR_materials_sheen writes it.
template <typename T> T visibilitySheenCharlie(T NdotL, T NdotV, T alpha) {
    auto l = [alpha](T x) {
        const T o = (T(1) - alpha) * (T(1) - alpha);
        const T a = glm::mix(T(21.5473), T(25.3245), o), b = glm::mix(T(3.82987), T(3.32435), o);
        const T c = glm::mix(T(0.19823), T(0.16801), o), d = glm::mix(T(-1.97760), T(-1.27393), o);
        const T e = glm::mix(T(-4.32054), T(-4.85967), o);
        return a / (T(1) + b * std::pow(x, c)) + d * x + e;
    };
    auto lambda = [&](T c) { return std::abs(c) < T(0.5) ? std::exp(l(c)) : std::exp(T(2) * l(T(0.5)) - l(T(1) - c)); };
    return T(1) / ((T(1) + lambda(NdotV) + lambda(NdotL)) * (T(4) * NdotV * NdotL));
}

/// The full layered BRDF times N.L: common_brdf.glsl `evaluateLayeredBrdfCos`.
///   f = coat(F_c) + (1 - coat F_c) (sheen + sheenAlbedoScaling base)
/// brdf = (metallic, roughness, specular, occlusion) and sheen = (sheen colour RGB, sheen
/// roughness) and coat = (weight, roughness) exactly as the G-buffer stores them
/// (gbuffer/include/dfb/gbuffer/DeepBuffer.h). `sheenEnabled`/`coatEnabled` mirror the
/// SHADE_SHEEN/SHADE_COAT specialisation defines (false: the lobe is left out).
/// Sheen (KHR_materials_sheen): f_sheen = sheenColor D_Charlie(alpha_s) V, alpha_s =
/// max(sheenRoughness^2, MIN_ALPHA), skipped when the sheen colour is 0 (the extension: "the whole
/// sheen layer is disabled").
/// Coat (KHR_materials_clearcoat, fresnel_coat with IOR 1.5): F_c = 0.04 + 0.96 (1 - |N.V|)^5
/// (the extension's Fresnel of the view angle, so the base is dimmed by the same factor for every
/// light direction and coat over a base of albedo <= 1 stays <= 1; not reciprocal, as the
/// extension's "Discussion" says), the coat lobe F_c D V with alpha_c = max(coatRoughness^2,
/// MIN_ALPHA), skipped when coat = 0.
/// Differs:
/// - sheen alpha_s = sheenRoughness^2 (as Filament and the glTF Sample Viewer do); the
///   extension's implementation note writes alphaG = sheenRoughness.
/// - sheen albedo scaling 1 - max3(sheenColor), i.e. the extension's
///   1 - max3(sheenColor) E(N.V) with E = 1 (no lookup table): the base is darkened more than the
///   extension's, never brightened.
/// - coat normal: the shading normal N (the G-buffer holds no clear-coat normal); the extension
///   uses clearcoatNormal, the geometric normal when no clearcoatNormalTexture is given.
template <typename T>
vec3<T> evaluateLayeredBrdfCos(const vec3<T>& N, const vec3<T>& L, const vec3<T>& V, const vec3<T>& albedo,
                               const vec4<T>& brdf, const vec4<T>& sheen, const vec2<T>& coat, bool sheenEnabled = true,
                               bool coatEnabled = true) {
    const T NdotL = glm::dot(N, L);
    if (NdotL <= T(0)) return vec3<T>(T(0));
    vec3<T> base = evaluateBrdfCos(N, L, V, albedo, brdf.x, brdf.y, brdf.z);
    const T NdotV = std::max(glm::dot(N, V), T(MIN_NDOTV));
    const HalfVector<T> h = halfVector(N, L, V);
    if (sheenEnabled && (sheen.r > T(0) || sheen.g > T(0) || sheen.b > T(0))) {
        const T sheenAlpha = std::max(sheen.a * sheen.a, T(MIN_ALPHA));
        const vec3<T> fs = vec3<T>(sheen) * (distributionCharlie(h.NdotH, sheenAlpha) * visibilityNeubelt(NdotL, NdotV));
        const T scaling = T(1) - std::max(std::max(sheen.r, sheen.g), sheen.b);
        base = base * scaling + fs * NdotL;
    }
    if (coatEnabled && coat.x > T(0)) {
        const T alpha = std::max(coat.y * coat.y, T(MIN_ALPHA));
        const T Fc = T(0.04) + T(0.96) * std::pow(T(1) - saturate(NdotV), T(5));
        const T fc = Fc * distributionGGX(h.NdotH, alpha) * visibilitySmithGGX(NdotL, NdotV, alpha);
        base = base * (T(1) - coat.x * Fc) + vec3<T>(coat.x * fc * NdotL);
    }
    return base;
}

} // namespace dfb::lightmath
