#pragma once
// Real spherical harmonics of order 3 (bands l = 0, 1, 2: nine coefficients) and 5 (25, the baked
// transfer's) for the environment light's diffuse term with visibility: precomputed radiance
// transfer (Sloan, Kautz and Snyder, "Precomputed Radiance Transfer for Real-Time Rendering in Dynamic, Low-Frequency Lighting
// Environments", SIGGRAPH 2002, section 4: diffuse shadowed transfer), and the unshadowed
// irradiance of Ramamoorthi and Hanrahan, "An Efficient Representation for Irradiance
// Environment Maps", SIGGRAPH 2001 (eqs. 7-9). World space, glTF's +Y up. The GLSL mirror is
// server/shaders/common_env.glsl (shEvaluate, shEvaluate25, line for line).
//
// Conventions, the one place they are written (docs/lighting.md, "Environment light"):
// - basis Y_0..Y_8 below, without the Condon-Shortley phase (signs only need to agree between
//   projection and evaluation);
// - a radiance function's coefficients L_i = integral over the sphere of L(w) Y_i(w) dw;
// - a sample's diffuse transfer T_i = (1/pi) integral of V(w) max(0, N.w) Y_i(w) dw, V the
//   visibility of the environment from the sample (1 where a ray escapes the scene), N its shading
//   normal; the sample's diffuse radiance is albedo x sum_i L_i T_i (a white furnace with V = 1
//   gives albedo x L).

#include "Scalar.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace dfb::lightmath {

/// Coefficients per function (bands 0..2).
constexpr int SH_COEFFICIENTS = 9;

/// Y_0..Y_8 at the unit direction d.
template <typename T> std::array<T, SH_COEFFICIENTS> shEvaluate(const vec3<T>& d) {
    return {T(0.282094791773878), // 1 / (2 sqrt(pi))
            T(0.488602511902920) * d.y, // sqrt(3 / (4 pi))
            T(0.488602511902920) * d.z,
            T(0.488602511902920) * d.x,
            T(1.092548430592079) * d.x * d.y, // sqrt(15 / (4 pi))
            T(1.092548430592079) * d.y * d.z,
            T(0.315391565252520) * (T(3) * d.z * d.z - T(1)), // sqrt(5 / (16 pi))
            T(1.092548430592079) * d.x * d.z,
            T(0.546274215296040) * (d.x * d.x - d.y * d.y)}; // sqrt(15 / (16 pi))
}

/// Bands shEvaluateBands evaluates at most (100 coefficients).
constexpr int SH_MAX_BANDS = 10;

/// Y_0 .. Y_{bands^2 - 1} at the unit direction d, any number of bands up to SH_MAX_BANDS, coefficient
/// l (l + 1) + m for band l, m = -l..l, in shEvaluate's convention (its nine values for bands 0-2:
/// polar axis +Z, m > 0 with cos m phi and m < 0 with sin |m| phi of phi = atan2(y, x), no
/// Condon-Shortley phase): Y_lm = sqrt(2) K_lm P_l^|m|(z) (cos or sin) |m| phi for m != 0, K_l0
/// P_l(z) for m = 0, with K_lm = sqrt((2l + 1) (l - |m|)! / (4 pi (l + |m|)!)) and the associated
/// Legendre functions by their standard recurrences (Green, "Spherical Harmonic Lighting: The
/// Gritty Details", GDC 2003, section 2). Higher bands than the engine's three are what a finer
/// visibility transfer would store: dfb-env-bench --transfer-bands measures what each would give.
/// K_lm = sqrt((2l + 1) (l - m)! / (4 pi (l + m)!)), 0 <= m <= l < SH_MAX_BANDS, from a table made
/// once ((l - m)! / (l + m)! as a running product: exact enough for these small l).
inline double shNormalisation(int l, int m) {
    static const auto table = [] {
        std::array<double, SH_MAX_BANDS * SH_MAX_BANDS> k{};
        for (int a = 0; a < SH_MAX_BANDS; ++a)
            for (int b = 0; b <= a; ++b) {
                double ratio = 1.0;
                for (int i = a - b + 1; i <= a + b; ++i) ratio /= double(i);
                k[size_t(a * SH_MAX_BANDS + b)] = std::sqrt(double(2 * a + 1) * ratio / (4.0 * 3.14159265358979323846));
            }
        return k;
    }();
    return table[size_t(l * SH_MAX_BANDS + m)];
}

template <typename T> void shEvaluateBands(const vec3<T>& d, int bands, T* out) {
    const double z = std::clamp(double(d.z), -1.0, 1.0), phi = std::atan2(double(d.y), double(d.x));
    const double sinTheta = std::sqrt(std::max(0.0, (1.0 - z) * (1.0 + z)));
    bands = std::clamp(bands, 0, SH_MAX_BANDS);
    for (int m = 0; m < bands; ++m) {
        const double cosM = std::cos(m * phi), sinM = std::sin(m * phi);
        // P_m^m = (2m - 1)!! sin^m theta, then P_{m+1}^m = z (2m + 1) P_m^m, then the three-term
        // recurrence (l - m) P_l^m = z (2l - 1) P_{l-1}^m - (l + m - 1) P_{l-2}^m.
        double pmm = 1.0;
        for (int i = 1; i <= m; ++i) pmm *= double(2 * i - 1) * sinTheta;
        double prev = 0.0, cur = pmm;
        for (int l = m; l < bands; ++l) {
            if (l == m + 1) prev = cur, cur = z * double(2 * m + 1) * pmm;
            else if (l > m + 1) {
                const double next = (z * double(2 * l - 1) * cur - double(l + m - 1) * prev) / double(l - m);
                prev = cur, cur = next;
            }
            const double k = shNormalisation(l, m);
            if (m == 0) {
                out[l * (l + 1)] = T(k * cur);
            } else {
                out[l * (l + 1) + m] = T(std::sqrt(2.0) * k * cur * cosM);
                out[l * (l + 1) - m] = T(std::sqrt(2.0) * k * cur * sinM);
            }
        }
    }
}

/// Bands and coefficients of the finest baked transfer (bands 0..4; DeepBuffer's
/// ENV_TRANSFER_COEFFICIENTS): the most the environment light's shadowed diffuse reads.
constexpr int SH_TRANSFER_BANDS = 5;
constexpr int SH_TRANSFER_COEFFICIENTS = SH_TRANSFER_BANDS * SH_TRANSFER_BANDS;

/// Y_0..Y_24 at the unit direction d: shEvaluate's nine, then bands 3 and 4 as polynomials in
/// (x, y, z), in shEvaluateBands' order and convention (the unit test holds them to it). The GLSL
/// mirror is common_env.glsl's shEvaluate25.
template <typename T> std::array<T, SH_TRANSFER_COEFFICIENTS> shEvaluate25(const vec3<T>& d) {
    std::array<T, SH_TRANSFER_COEFFICIENTS> y{};
    const auto nine = shEvaluate(d);
    std::copy(nine.begin(), nine.end(), y.begin());
    const T x = d.x, v = d.y, z = d.z, x2 = x * x, v2 = v * v, z2 = z * z;
    y[9] = T(0.590043589926644) * v * (T(3) * x2 - v2); // sqrt(35 / (32 pi))
    y[10] = T(2.890611442640554) * x * v * z;          // sqrt(105 / (4 pi))
    y[11] = T(0.457045799464466) * v * (T(5) * z2 - T(1)); // sqrt(21 / (32 pi))
    y[12] = T(0.373176332590115) * z * (T(5) * z2 - T(3)); // sqrt(7 / (16 pi))
    y[13] = T(0.457045799464466) * x * (T(5) * z2 - T(1));
    y[14] = T(1.445305721320277) * z * (x2 - v2); // sqrt(105 / (16 pi))
    y[15] = T(0.590043589926644) * x * (x2 - T(3) * v2);
    y[16] = T(2.503342941796705) * x * v * (x2 - v2);            // 3/4 sqrt(35 / pi)
    y[17] = T(1.770130769779930) * v * z * (T(3) * x2 - v2);     // 3/4 sqrt(35 / (2 pi))
    y[18] = T(0.946174695757560) * x * v * (T(7) * z2 - T(1));   // 3/4 sqrt(5 / pi)
    y[19] = T(0.669046543557289) * v * z * (T(7) * z2 - T(3));   // 3/4 sqrt(5 / (2 pi))
    y[20] = T(0.105785546915204) * (T(35) * z2 * z2 - T(30) * z2 + T(3)); // 3/16 sqrt(1 / pi)
    y[21] = T(0.669046543557289) * x * z * (T(7) * z2 - T(3));
    y[22] = T(0.473087347878780) * (x2 - v2) * (T(7) * z2 - T(1)); // 3/8 sqrt(5 / pi)
    y[23] = T(1.770130769779930) * x * z * (x2 - T(3) * v2);
    y[24] = T(0.625835735449176) * (x2 * (x2 - T(3) * v2) - v2 * (T(3) * x2 - v2)); // 3/16 sqrt(35 / pi)
    return y;
}

/// The band of coefficient i (i < SH_TRANSFER_COEFFICIENTS): l with l^2 <= i < (l + 1)^2.
constexpr int shBand(int i) { return i < 1 ? 0 : (i < 4 ? 1 : (i < 9 ? 2 : (i < 16 ? 3 : 4))); }

/// The clamped cosine's convolution per band divided by pi (Ramamoorthi and Hanrahan 2001,
/// eq. 8: A_0 = pi, A_1 = 2 pi / 3, A_2 = pi / 4, A_3 = 0, A_4 = -pi / 24): the unshadowed
/// transfer of normal N is T_i = shCosineBand(band(i)) Y_i(N).
template <typename T> T shCosineBand(int band) {
    switch (band) {
    case 0: return T(1);
    case 1: return T(2) / T(3);
    case 2: return T(0.25);
    case 3: return T(0);
    default: return T(-1) / T(24);
    }
}

/// The unshadowed diffuse transfer of a sample with shading normal N (V = 1 everywhere).
template <typename T> std::array<T, SH_COEFFICIENTS> shUnshadowedTransfer(const vec3<T>& N) {
    std::array<T, SH_COEFFICIENTS> y = shEvaluate(N);
    for (int i = 0; i < SH_COEFFICIENTS; ++i) y[size_t(i)] *= shCosineBand<T>(shBand(i));
    return y;
}

/// shUnshadowedTransfer on five bands (bands 3 and 4 of a clamped cosine: 0 and -1/24 Y_i(N)).
template <typename T> std::array<T, SH_TRANSFER_COEFFICIENTS> shUnshadowedTransfer25(const vec3<T>& N) {
    std::array<T, SH_TRANSFER_COEFFICIENTS> y = shEvaluate25(N);
    for (int i = 0; i < SH_TRANSFER_COEFFICIENTS; ++i) y[size_t(i)] *= shCosineBand<T>(shBand(i));
    return y;
}

/// The five bands' rotation: D with Y(R w) = D Y(w) (band by band; D_ij = 0 across bands), so
/// that the coefficients of a function turned by R (L'(R w) = L(w)) are L' = D L. Each band's
/// block is D_ij = integral of Y_i(R w) Y_j(w) dw, a polynomial of degree 2l <= 8 on the sphere:
/// integrated exactly by the product rule of 6 Gauss-Legendre nodes in cos theta (exact to
/// degree 11) and 12 equal steps in phi (exact for frequencies up to 11). A rotation then costs
/// 72 evaluations instead of re-projecting the map (Environment.h envProjectSh: 2.5 ms at 128 x 64
/// texels), and gives the same coefficients to rounding (lightmath_sh_test). Row-major 25 x 25.
inline std::array<double, SH_TRANSFER_COEFFICIENTS * SH_TRANSFER_COEFFICIENTS> shRotation25(const glm::dmat3& R) {
    constexpr int NZ = 6, NPHI = 12;
    constexpr double pi = 3.14159265358979323846;
    // Gauss-Legendre nodes and weights on [-1, 1]: Newton on P_6 from Chebyshev guesses.
    std::array<double, NZ> zs{}, ws{};
    for (int i = 0; i < NZ; ++i) {
        double x = std::cos(pi * (i + 0.75) / (NZ + 0.5)), dp = 1;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1, p1 = x;
            for (int k = 2; k <= NZ; ++k) {
                const double p2 = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            dp = NZ * (x * p1 - p0) / (x * x - 1);
            const double dx = p1 / dp;
            x -= dx;
            if (std::abs(dx) < 1e-16) break;
        }
        zs[size_t(i)] = x;
        ws[size_t(i)] = 2 / ((1 - x * x) * dp * dp);
    }
    constexpr int K = SH_TRANSFER_COEFFICIENTS;
    std::array<double, K * K> D{};
    for (int i = 0; i < NZ; ++i)
        for (int j = 0; j < NPHI; ++j) {
            const double z = zs[size_t(i)], r = std::sqrt(std::max(0.0, 1 - z * z)), phi = 2 * pi * (j + 0.5) / NPHI;
            const glm::dvec3 w(r * std::cos(phi), r * std::sin(phi), z);
            const double weight = ws[size_t(i)] * 2 * pi / NPHI;
            const auto a = shEvaluate25(R * w), b = shEvaluate25(w);
            for (int p = 0; p < K; ++p)
                for (int q = 0; q < K; ++q)
                    if (shBand(p) == shBand(q)) D[size_t(p * K + q)] += weight * a[size_t(p)] * b[size_t(q)];
        }
    return D;
}

/// The coefficients of function L turned by R (shRotation25).
template <typename V> std::array<V, SH_TRANSFER_COEFFICIENTS> shRotate25(const std::array<V, SH_TRANSFER_COEFFICIENTS>& L,
                                                                      const glm::dmat3& R) {
    constexpr int K = SH_TRANSFER_COEFFICIENTS;
    const auto D = shRotation25(R);
    std::array<V, K> out{};
    for (int p = 0; p < K; ++p)
        for (int q = 0; q < K; ++q) out[size_t(p)] += L[size_t(q)] * D[size_t(p * K + q)];
    return out;
}

} // namespace dfb::lightmath
