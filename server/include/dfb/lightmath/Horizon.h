#pragma once
// The near-field horizon: per G-buffer sample, the elevation up to which the scene closes the sky
// within a short distance R, at HORIZON_AZIMUTHS azimuths about the geometric normal (horizon
// mapping: Max, "Horizon Mapping: Shadows for Bump-Mapped Surfaces", The Visual Computer 1988;
// Sloan and Cohen, "Interactive Horizon Mapping", EGWR 2000). The bake traces it once (the camera
// is fixed, so are the samples; DeepBuffer::horizon) and the relight shaders test each light
// direction against it beside the shadow map: occluders closer than a texel or two along the ray,
// a curved mesh's own bumps near its terminator and contacts seen at grazing angles, are below any
// shadow map's resolution and bias (docs/lighting.md, "Shadows"). The GLSL mirror is
// server/shaders/common_horizon.glsl; tests/unit/lightmath_horizon_test.cpp holds the two to the
// same answers.

#include "Scalar.h"

#include <algorithm>
#include <cmath>

namespace dfb::lightmath {

/// Azimuths of a sample's horizon (DeepBuffer's HORIZON_AZIMUTHS). 16 (22.5 degrees apart)
/// against ray-traced shadows on the default scene: leaks 61 -> 23 of 2,125 shadowed pixels under
/// a sun, false shadows 21 -> 22; 8 azimuths let 25 through and add 26 false ones.
constexpr int HORIZON_AZIMUTHS = 16;

/// The tangent frame the azimuths are measured in, about the unit normal n: azimuth phi is the
/// direction cos(phi) t + sin(phi) b (Duff, Burgess, Christensen, Hery, Kensler, Liani and
/// Villemin, "Building an Orthonormal Basis, Revisited", JCGT 2017). The branch is on n.z >= 0
/// so that -0 and +0 pick the same side in C++ and GLSL; the bake takes the frame of the normal
/// as the engine reads it (half floats), so that both sides meet the same branch.
template <typename T> void horizonFrame(const vec3<T>& n, vec3<T>& t, vec3<T>& b) {
    const T sign = n.z >= T(0) ? T(1) : T(-1);
    const T a = T(-1) / (sign + n.z);
    const T c = n.x * n.y * a;
    t = vec3<T>(T(1) + sign * n.x * n.x * a, sign * c, -sign * n.x);
    b = vec3<T>(c, sign + n.y * n.y * a, -n.y);
}

/// The direction at azimuth index k (0 .. HORIZON_AZIMUTHS - 1) and elevation sine s in [0, 1].
template <typename T> vec3<T> horizonDirection(const vec3<T>& n, const vec3<T>& t, const vec3<T>& b, int k, T s) {
    const T phi = T(2 * 3.14159265358979323846) * T(k) / T(HORIZON_AZIMUTHS);
    const T c = std::sqrt(std::max(T(0), T(1) - s * s));
    return c * (std::cos(phi) * t + std::sin(phi) * b) + s * n;
}

/// The horizon's elevation sine towards the unit direction L: linear in azimuth between the two
/// stored azimuths around L's. h: the sample's HORIZON_AZIMUTHS sines, each in [0, 1].
template <typename T> T horizonSine(const T* h, const vec3<T>& n, const vec3<T>& L) {
    vec3<T> t, b;
    horizonFrame(n, t, b);
    const T x = dot(L, t), y = dot(L, b);
    if (x == T(0) && y == T(0)) return T(0); // along the normal: above every horizon
    T u = std::atan2(y, x) * T(HORIZON_AZIMUTHS / (2 * 3.14159265358979323846));
    if (u < T(0)) u += T(HORIZON_AZIMUTHS);
    const int k0 = int(u) % HORIZON_AZIMUTHS, k1 = (k0 + 1) % HORIZON_AZIMUTHS;
    const T f = u - std::floor(u);
    return h[k0] + f * (h[k1] - h[k0]);
}

/// Whether light from the unit direction L reaches the sample past its near field: above its
/// geometric plane (a facet facing away from the light is shadowed by itself) and above the
/// horizon there.
template <typename T> bool horizonLit(const T* h, const vec3<T>& n, const vec3<T>& L) {
    const T e = dot(n, L);
    return e > T(0) && e > horizonSine(h, n, L);
}

} // namespace dfb::lightmath
