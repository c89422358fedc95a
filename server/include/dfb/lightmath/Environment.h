#pragma once
// The environment light's math (docs/lighting.md, "Environment light"): the latitude-longitude
// parameterisation and the map's rotation, the projection of a map onto the spherical harmonics
// of SphericalHarmonics.h, and the split-sum approximation of the GGX lobe against a prefiltered
// map (Karis, "Real Shading in Unreal Engine 4", SIGGRAPH 2013 course notes: prefiltered
// radiance x the DFG table's scale and bias of F0 and F90). The GLSL mirror of the
// parameterisation is server/shaders/common_env.glsl (envLatLong).

#include "Brdf.h"
#include "Scalar.h"
#include "SphericalHarmonics.h"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace dfb::lightmath {

constexpr double ENV_PI = 3.14159265358979323846;

/// The map's direction of texture coordinate (u, v) in [0, 1]^2: u across (0.5 = the centre
/// column, looking along -Z; u grows towards +X), v down (0 = the top row, +Y).
template <typename T> vec3<T> envDirection(T u, T v) {
    const T phi = T(2 * ENV_PI) * (u - T(0.5)), theta = T(ENV_PI) * v;
    return {std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi)};
}

/// The inverse of envDirection for a unit direction: (u, v).
template <typename T> vec2<T> envLatLong(const vec3<T>& d) {
    const T u = T(0.5) + std::atan2(d.x, -d.z) / T(2 * ENV_PI);
    const T v = std::acos(std::max(T(-1), std::min(T(1), d.y))) / T(ENV_PI);
    return {u, v};
}

/// World direction = R x map direction, R = Ry(yaw) Rx(pitch) Rz(roll), degrees (Light::
/// envRotationDeg): the map is rolled about +Z, then pitched about +X, then turned about +Y.
inline glm::dmat3 envRotation(const std::array<float, 3>& yawPitchRollDeg) {
    const glm::dmat4 y = glm::rotate(glm::dmat4(1.0), glm::radians(double(yawPitchRollDeg[0])), glm::dvec3(0, 1, 0));
    const glm::dmat4 x = glm::rotate(glm::dmat4(1.0), glm::radians(double(yawPitchRollDeg[1])), glm::dvec3(1, 0, 0));
    const glm::dmat4 z = glm::rotate(glm::dmat4(1.0), glm::radians(double(yawPitchRollDeg[2])), glm::dvec3(0, 0, 1));
    return glm::dmat3(y * x * z);
}

/// The solid angle of texel row j of a w x h latitude-longitude map.
inline double envTexelSolidAngle(int j, int w, int h) {
    const double t0 = ENV_PI * double(j) / h, t1 = ENV_PI * double(j + 1) / h;
    return (2 * ENV_PI / w) * (std::cos(t0) - std::cos(t1));
}

/// The unit direction of texture coordinate (s, t) in [0, 1]^2 on cube-map face `face` (0..5:
/// +X, -X, +Y, -Y, +Z, -Z), the inverse of OpenGL's face selection (OpenGL 4.5 core
/// specification, section 8.13, table 8.19: sc, tc against the major axis ma, s = (sc / |ma| +
/// 1) / 2, t = (tc / |ma| + 1) / 2). The engine's prefiltered environment is a cube map
/// (EnvironmentMap.h) read with a direction, so that the shader computes no latitude and
/// longitude per read.
inline glm::dvec3 cubeDirection(int face, double s, double t) {
    const double sc = 2 * s - 1, tc = 2 * t - 1;
    glm::dvec3 d;
    switch (face) {
    case 0: d = {1, -tc, -sc}; break;
    case 1: d = {-1, -tc, sc}; break;
    case 2: d = {sc, 1, tc}; break;
    case 3: d = {sc, -1, -tc}; break;
    case 4: d = {sc, -tc, 1}; break;
    default: d = {-sc, -tc, -1}; break;
    }
    return glm::normalize(d);
}

/// OpenGL's selection for a direction (the table cubeDirection inverts): its face and (s, t).
inline int cubeFace(const glm::dvec3& d, glm::dvec2& st) {
    const glm::dvec3 a = glm::abs(d);
    int face;
    double sc, tc, ma;
    if (a.x >= a.y && a.x >= a.z) {
        face = d.x >= 0 ? 0 : 1, ma = a.x, sc = d.x >= 0 ? -d.z : d.z, tc = -d.y;
    } else if (a.y >= a.z) {
        face = d.y >= 0 ? 2 : 3, ma = a.y, sc = d.x, tc = d.y >= 0 ? d.z : -d.z;
    } else {
        face = d.z >= 0 ? 4 : 5, ma = a.z, sc = d.z >= 0 ? d.x : -d.x, tc = -d.y;
    }
    st = glm::dvec2(sc / ma + 1, tc / ma + 1) * 0.5;
    return face;
}

/// L_0..L_24 (SphericalHarmonics.h: five bands, as many as a baked transfer holds; the
/// irradiance reads the first nine) of an RGB(A) float map (`channels` floats per texel, row 0 at
/// the top) turned by `rotation` (envRotation): the integral of the texel-constant function, each
/// texel's Y_i taken at 2 x 2 sub-texel directions weighted by their solid angles (texel centres
/// alone leave a 1e-4 error in a constant map's bands 1-2 at 64 rows; this, 3e-5).
inline std::array<glm::dvec3, SH_TRANSFER_COEFFICIENTS> envProjectSh(const float* texels, int w, int h, int channels,
                                                                      const glm::dmat3& rotation) {
    std::array<glm::dvec3, SH_TRANSFER_COEFFICIENTS> L{};
    for (int j = 0; j < h; ++j) {
        for (int sj = 0; sj < 2; ++sj) {
            const double dOmega = envTexelSolidAngle(2 * j + sj, 2 * w, 2 * h);
            for (int i = 0; i < w; ++i) {
                const float* t = texels + (size_t(j) * size_t(w) + size_t(i)) * size_t(channels);
                const glm::dvec3 c(t[0], t[1], t[2]);
                for (int si = 0; si < 2; ++si) {
                    const glm::dvec3 d = rotation * envDirection((2 * i + si + 0.5) / (2 * w), (2 * j + sj + 0.5) / (2 * h));
                    const auto y = shEvaluate25(d);
                    for (int k = 0; k < SH_TRANSFER_COEFFICIENTS; ++k) L[size_t(k)] += c * (y[size_t(k)] * dOmega);
                }
            }
        }
    }
    return L;
}

/// The normal of row j, column i of the irradiance grid: rows from the pole +Y (j = 0) to -Y
/// (j = outH - 1) inclusive, so that the poles are grid points; columns at u = (i + 0.5) / outW.
inline glm::dvec3 envIrradianceNormal(int i, int j, int outW, int outH) {
    return envDirection((i + 0.5) / outW, double(j) / double(outH - 1));
}

/// The map's exact unshadowed diffuse irradiance over pi, E(N) / pi = (1/pi) integral of
/// L(w) max(0, N.w) dw, at the normals envIrradianceNormal of an outW x outH grid (RGBA), from a
/// w x h copy of the map turned by `rotation`. relight_env.frag adds what the order-3 expansion
/// misses of it (the grid holds E minus the expansion's E, smooth and small, interpolated), and
/// scales by the expansion's ratio of shadowed to unshadowed irradiance: open surfaces get the
/// map's irradiance without order-3 truncation (3.9 % on the courtyard map facing up) and only the
/// visibility is approximated.
inline std::vector<float> envIrradianceMap(const float* texels, int w, int h, int channels, const glm::dmat3& rotation,
                                           int outW, int outH) {
    std::vector<glm::dvec3> dirs(size_t(w) * size_t(h));
    std::vector<glm::dvec3> weighted(dirs.size());
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const size_t k = size_t(j) * size_t(w) + size_t(i);
            const float* t = texels + k * size_t(channels);
            dirs[k] = rotation * envDirection((i + 0.5) / w, (j + 0.5) / h);
            weighted[k] = glm::dvec3(t[0], t[1], t[2]) * (envTexelSolidAngle(j, w, h) / ENV_PI);
        }
    std::vector<float> out(size_t(outW) * size_t(outH) * 4, 1.f);
    for (int j = 0; j < outH; ++j)
        for (int i = 0; i < outW; ++i) {
            const glm::dvec3 N = envIrradianceNormal(i, j, outW, outH);
            glm::dvec3 E(0.0);
            for (size_t k = 0; k < dirs.size(); ++k) {
                const double c = glm::dot(N, dirs[k]);
                if (c > 0) E += weighted[k] * c;
            }
            float* o = &out[(size_t(j) * size_t(outW) + size_t(i)) * 4];
            o[0] = float(E.x);
            o[1] = float(E.y);
            o[2] = float(E.z);
        }
    return out;
}

/// Point i of n of the Hammersley set in [0, 1)^2 (radical inverse in base 2).
inline glm::dvec2 hammersley(uint32_t i, uint32_t n) {
    uint32_t b = i;
    b = (b << 16u) | (b >> 16u);
    b = ((b & 0x55555555u) << 1u) | ((b & 0xAAAAAAAAu) >> 1u);
    b = ((b & 0x33333333u) << 2u) | ((b & 0xCCCCCCCCu) >> 2u);
    b = ((b & 0x0F0F0F0Fu) << 4u) | ((b & 0xF0F0F0F0u) >> 4u);
    b = ((b & 0x00FF00FFu) << 8u) | ((b & 0xFF00FF00u) >> 8u);
    return {(i + 0.5) / n, double(b) * 2.3283064365386963e-10};
}

/// A GGX half vector about +Z for the sample point xi (pdf D(h) h.z; Walter et al., "Microfacet
/// Models for Refraction through Rough Surfaces", EGSR 2007, eqs. 35-36).
inline glm::dvec3 ggxHalfVector(const glm::dvec2& xi, double alpha) {
    const double phi = 2 * ENV_PI * xi.x;
    const double cosTheta = std::sqrt((1 - xi.y) / (1 + (alpha * alpha - 1) * xi.y));
    const double sinTheta = std::sqrt(std::max(0.0, 1 - cosTheta * cosTheta));
    return {sinTheta * std::cos(phi), sinTheta * std::sin(phi), cosTheta};
}

/// The weight of one reflected direction of the GGX lobe (roughness -> alpha) sampled through
/// ggxHalfVector: the BRDF's D Vis N.L over the half vector's density D N.H / (4 V.H), without
/// the Fresnel factor, Vis 4 V.H N.L / N.H (dfgIntegral's sum); 0 below the surface. The specular
/// lobe the bake stores per sample (DeepBuffer::envLobe) is these weights' visible share and
/// their visible mean direction.
inline double ggxLobeWeight(double NdotL, double NdotV, double NdotH, double VdotH, double alpha) {
    if (NdotL <= 0 || VdotH <= 0 || NdotH <= 0) return 0;
    return visibilitySmithGGX(NdotL, std::max(NdotV, MIN_NDOTV), alpha) * 4 * VdotH * NdotL / NdotH;
}

/// The split sum's second factor (Karis 2013): for the lobe D Vis N.L of roughness r at N.v,
/// the integrals A (of (1 - Fc) ...) and B (of Fc ...), Fc = (1 - v.h)^5, so that the reflected
/// radiance of a uniform environment of radiance 1 is F0 A + F90 B. `samples` GGX samples.
inline glm::dvec2 dfgIntegral(double NdotV, double roughness, int samples) {
    const double alpha = std::max(roughness * roughness, 1e-3);
    const glm::dvec3 V(std::sqrt(std::max(0.0, 1 - NdotV * NdotV)), 0.0, NdotV);
    glm::dvec2 ab(0.0);
    for (int i = 0; i < samples; ++i) {
        const glm::dvec3 H = ggxHalfVector(hammersley(uint32_t(i), uint32_t(samples)), alpha);
        const double VdotH = glm::dot(V, H);
        const glm::dvec3 L = 2.0 * VdotH * H - V;
        // f cos / pdf_L with pdf_L = D NdotH / (4 VdotH): Vis 4 VdotH NdotL / NdotH.
        const double g = ggxLobeWeight(L.z, NdotV, H.z, VdotH, alpha);
        if (g <= 0) continue;
        const double fc = std::pow(1 - VdotH, 5.0);
        ab += glm::dvec2((1 - fc) * g, fc * g);
    }
    return ab / double(samples);
}

/// The DFG table: size x size entries (A, B) of dfgIntegral at texel centres, N.v along x
/// ((i + 0.5) / size), roughness along y ((j + 0.5) / size), row-major (GL's upload order).
inline std::vector<float> dfgTable(int size, int samples) {
    std::vector<float> t(size_t(size) * size_t(size) * 2);
    for (int j = 0; j < size; ++j)
        for (int i = 0; i < size; ++i) {
            const glm::dvec2 ab = dfgIntegral((i + 0.5) / size, (j + 0.5) / size, samples);
            t[(size_t(j) * size_t(size) + size_t(i)) * 2] = float(ab.x);
            t[(size_t(j) * size_t(size) + size_t(i)) * 2 + 1] = float(ab.y);
        }
    return t;
}

/// The specular lobe's rings (DeepBuffer::envRings, format version 7): a GGX lobe sampled through
/// ggxHalfVector splits by its half vector's polar coordinate xi.y into ENV_LOBE_RINGS equal
/// shares of the sampling domain, the core about the mirror direction first and the tail last.
/// Each ring's visible part is read from the prefiltered map on its own, towards its mean
/// direction and as wide as it is (prefilterRoughnessForResultant): one isotropic read cannot
/// stand for both a grazing lobe's peak near the mirror direction and its long tail towards the
/// horizon (docs/lighting.md, "Environment light"). Rings, unlike clusters of the rays, add over
/// a merged sample's points. 3 by measurement (dfb-env-bench --specular-lobes, tabletop, 512 GGX
/// rays): 2 rings 8.7 / 9.3 % specular error (sunrise / interior), 3 rings 7.5 / 8.4 %, 4 rings
/// 7.4 / 8.1 %, per-ray k-means into 3 clusters 7.8 / 9.1 %.
constexpr int ENV_LOBE_RINGS = 3;

/// The ring of a GGX sample whose polar coordinate (ggxHalfVector's xi.y) is `v`, in [0, 1).
inline int lobeRing(double v) { return std::clamp(int(v * ENV_LOBE_RINGS), 0, ENV_LOBE_RINGS - 1); }

/// The mean resultant length |E[l]| (the mean cosine about its axis) of the prefiltered map's
/// kernel at roughness index i / (PREFILTER_KERNEL_STEPS - 1): GGX half vectors about N with
/// N = v = r, reflected directions weighted by N.l, as prefilterEnvironment (the engine's
/// EnvironmentMap.cpp) samples them; 4,096 Hammersley samples each, computed once.
constexpr int PREFILTER_KERNEL_STEPS = 101;
inline const std::vector<double>& prefilterKernelResultants() {
    static const std::vector<double> table = [] {
        std::vector<double> out(PREFILTER_KERNEL_STEPS, 1.0);
        constexpr uint32_t SAMPLES = 4096;
        for (int i = 1; i < PREFILTER_KERNEL_STEPS; ++i) {
            const double r = double(i) / (PREFILTER_KERNEL_STEPS - 1), alpha = std::max(r * r, 1e-3);
            double sum = 0, weight = 0;
            for (uint32_t k = 0; k < SAMPLES; ++k) {
                const glm::dvec3 h = ggxHalfVector(hammersley(k, SAMPLES), alpha);
                const double NdotL = 2 * h.z * h.z - 1; // l = reflect(-N, h)
                if (NdotL <= 0) continue;
                sum += NdotL * NdotL;
                weight += NdotL;
            }
            out[size_t(i)] = weight > 0 ? sum / weight : 0.0;
        }
        return out;
    }();
    return table;
}

/// The prefiltered map's roughness whose kernel has the mean resultant length `R` (a bundle of
/// directions' |sum w l| / sum w): 0 for R >= 1, 1 for R at or under the widest kernel's, linear
/// between the table's steps (it falls with roughness).
inline double prefilterRoughnessForResultant(double R) {
    const std::vector<double>& k = prefilterKernelResultants();
    if (!(R < 1.0)) return 0.0;
    for (size_t i = 1; i < k.size(); ++i)
        if (k[i] <= R) {
            const double f = (k[i - 1] - R) / std::max(k[i - 1] - k[i], 1e-12);
            return (double(i - 1) + f) / double(k.size() - 1);
        }
    return 1.0;
}

/// Octahedral encoding of a unit direction into [-1, 1]^2 (Meyer, Sorge, Hormann, Dachsbacher and
/// Sander, "On Floating-Point Normal Vectors", 2010; the layout of Cigolle, Donow, Evangelakos,
/// Mara, McGuire and Meyer, "A Survey of Efficient Representations for Independent Unit
/// Vectors", JCGT 2014): the G-buffer's bent specular direction (env.lobe.u, env.lobe.v). The
/// GLSL mirror is common_env.glsl octDecode.
template <typename T> vec2<T> octEncode(const vec3<T>& d) {
    const T l1 = std::abs(d.x) + std::abs(d.y) + std::abs(d.z);
    vec2<T> e = l1 > T(0) ? vec2<T>(d.x, d.y) / l1 : vec2<T>(T(0));
    if (d.z < T(0)) {
        const vec2<T> f(T(1) - std::abs(e.y), T(1) - std::abs(e.x));
        e = vec2<T>(e.x >= T(0) ? f.x : -f.x, e.y >= T(0) ? f.y : -f.y);
    }
    return e;
}

template <typename T> vec3<T> octDecode(const vec2<T>& e) {
    vec3<T> d(e.x, e.y, T(1) - std::abs(e.x) - std::abs(e.y));
    if (d.z < T(0)) {
        const vec2<T> f(T(1) - std::abs(d.y), T(1) - std::abs(d.x));
        d.x = d.x >= T(0) ? f.x : -f.x;
        d.y = d.y >= T(0) ? f.y : -f.y;
    }
    return glm::normalize(d);
}

} // namespace dfb::lightmath
