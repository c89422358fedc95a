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

#include <array>

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
