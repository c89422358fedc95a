#pragma once
// Real spherical harmonics of order 3 (bands l = 0, 1, 2: nine coefficients) for the environment
// light's diffuse term with visibility: precomputed radiance transfer (Sloan, Kautz and Snyder,
// "Precomputed Radiance Transfer for Real-Time Rendering in Dynamic, Low-Frequency Lighting
// Environments", SIGGRAPH 2002, section 4: diffuse shadowed transfer), and the unshadowed
// irradiance of Ramamoorthi and Hanrahan, "An Efficient Representation for Irradiance
// Environment Maps", SIGGRAPH 2001 (eqs. 7-9). World space, glTF's +Y up. The GLSL mirror is
// server/shaders/common_env.glsl (shEvaluate, line for line).
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

/// The band of coefficient i.
constexpr int shBand(int i) { return i == 0 ? 0 : (i < 4 ? 1 : 2); }

/// The clamped cosine's convolution per band divided by pi (Ramamoorthi and Hanrahan 2001,
/// eq. 8: A_0 = pi, A_1 = 2 pi / 3, A_2 = pi / 4): the unshadowed transfer of normal N is
/// T_i = shCosineBand(band(i)) Y_i(N).
template <typename T> T shCosineBand(int band) {
    return band == 0 ? T(1) : (band == 1 ? T(2) / T(3) : T(0.25));
}

/// The unshadowed diffuse transfer of a sample with shading normal N (V = 1 everywhere).
template <typename T> std::array<T, SH_COEFFICIENTS> shUnshadowedTransfer(const vec3<T>& N) {
    std::array<T, SH_COEFFICIENTS> y = shEvaluate(N);
    for (int i = 0; i < SH_COEFFICIENTS; ++i) y[size_t(i)] *= shCosineBand<T>(shBand(i));
    return y;
}

} // namespace dfb::lightmath
