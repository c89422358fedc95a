#pragma once
// Punctual light falloff as server/shaders/common_falloff.glsl computes it (called by
// relight_spot.frag shadeSample and spotMask, and relight_bendy.frag)
// from the LightBlock GlEngine fills: spot cone and penumbra, barn doors, inverse-square distance.
// Allocation-free C++ for float and double with GLSL names (STYLE.md). docs/lighting.md ("Spot
// light", "Barn doors and cookie", "Point light", "Directional light") states the same formulas;
// tests/gpu/lightmath_parity_test.cpp compares the GLSL with these functions on a grid, and
// tests/gpu/engine_glossy_test.cpp rendered spot and point lights.
//
// Sources: KHR_lights_punctual (Khronos, 2018): intensity in candela (point, spot) or lux
// (directional), inverse-square attenuation without range, and the cone falloff of its
// implementation note. Differs: that note squares a clamped linear ramp of the cosine between the
// outer and inner cone cosines; the shaders use GLSL's smoothstep between the same two cosines
// (the same ends, a different curve in between).

#include <dfb/lightmath/Scalar.h>

#include <glm/glm.hpp>

#include <algorithm>
#include <cmath>

namespace dfb::lightmath {

/// The cone's cosines as GlEngine passes them (LightBlock::lightCone.xy): x = cos(outer),
/// y = max(cos(max(outer - penumbra, 0)), cos(outer) + 1e-5), so that the smoothstep's edges stay
/// ordered (GLSL leaves smoothstep undefined for e0 >= e1) even for a zero penumbra.
/// Angles in radians: outer in (0, 85 deg], penumbra in [0, outer].
template <typename T> vec2<T> spotConeCosines(T outerRad, T penumbraRad) {
    const T cosOuter = std::cos(outerRad);
    const T cosInner = std::cos(std::max(outerRad - penumbraRad, T(0)));
    return {cosOuter, std::max(cosInner, cosOuter + T(1e-5))};
}

/// Cone falloff (relight_spot.frag): smoothstep(cos outer, cos inner, dot(-L, axis)), with L the
/// unit direction from the surface to the light and `axis` the spot's unit direction: 0 outside
/// the outer cone, 1 inside the inner one.
template <typename T> T spotCone(const vec2<T>& cosines, const vec3<T>& L, const vec3<T>& axis) {
    return smoothstep(cosines.x, cosines.y, glm::dot(-L, axis));
}

/// Inverse-square distance falloff 1/d^2 (KHR_lights_punctual: no range cut-off), with d^2 clamped
/// to 1e-12 as the shader does (a receiver at the light).
template <typename T> T inverseSquare(T dist2) { return T(1) / std::max(dist2, T(1e-12)); }

/// The spot's frame, as its shadow frustum's (GlEngine: lightRight, lightUp): right =
/// normalize(axis x up) with up = +Y (+X when |axis.y| > 0.99, within about 8 degrees of
/// vertical), up' = right x axis.
template <typename T> struct SpotFrame {
    vec3<T> axis, right, up;
};
/// The one light frame of the product: the engine's shadow frusta, barn doors and cookies, the
/// BendyLight's control-point frame (uL = axis, vL = up, wL = right; BendyChain.h lightFrame) and
/// the browser's mirror (tested against values this writes) all use it.
template <typename T> vec3<T> frameUpHint(const vec3<T>& axis) {
    return std::abs(axis.y) > T(0.99) ? vec3<T>(T(1), T(0), T(0)) : vec3<T>(T(0), T(1), T(0));
}
template <typename T> SpotFrame<T> spotFrame(const vec3<T>& direction) {
    SpotFrame<T> f;
    f.axis = glm::normalize(direction);
    f.right = glm::normalize(glm::cross(f.axis, frameUpHint(f.axis)));
    f.up = glm::cross(f.right, f.axis);
    return f;
}

/// Half-width of a barn door's soft edge: a quarter of a degree either side (relight_spot.frag).
constexpr double BARN_DOOR_EDGE_RAD = 0.00436332;
static_assert(BARN_DOOR_EDGE_RAD > 0.25 * 3.14159265358979 / 180.0 - 1e-8 &&
              BARN_DOOR_EDGE_RAD < 0.25 * 3.14159265358979 / 180.0 + 1e-8);

/// The door angle GlEngine passes for a rig angle (Light::barnDoorsDeg): radians, and an open door
/// (>= 90 degrees) becomes 10 rad, out of atan's reach (|atan| < pi/2), so it never cuts.
template <typename T> T barnDoorRadians(T degrees) {
    return degrees >= T(90) ? T(10) : degrees * T(3.14159265358979323846) / T(180);
}

/// Barn doors (relight_spot.frag spotMask): for the unit direction `fromLight` (light to point),
/// x = D.right, y = D.up, z = D.axis (z <= 0: 0), ax = atan(x, z), ay = atan(y, z), and with
/// s(b, a) = smoothstep(b - edge, b + edge, a), doors = (left, right, top, bottom) in radians:
/// (1 - s(left, -ax)) (1 - s(right, ax)) (1 - s(top, ay)) (1 - s(bottom, -ay)).
template <typename T> T barnDoors(const SpotFrame<T>& f, const vec4<T>& doors, const vec3<T>& fromLight) {
    const T z = glm::dot(fromLight, f.axis);
    if (z <= T(0)) return T(0);
    const T x = glm::dot(fromLight, f.right), y = glm::dot(fromLight, f.up);
    const T ax = std::atan2(x, z), ay = std::atan2(y, z);
    const T e = T(BARN_DOOR_EDGE_RAD);
    return (T(1) - smoothstep(doors.x - e, doors.x + e, -ax)) * (T(1) - smoothstep(doors.y - e, doors.y + e, ax)) *
           (T(1) - smoothstep(doors.z - e, doors.z + e, ay)) * (T(1) - smoothstep(doors.w - e, doors.w + e, -ay));
}

/// Everything relight_spot.frag multiplies f(L, V) N.L and the light's colour x intensity by for
/// a spot light without shadows or cookie at `lightPos` with frame `f` and cone `cosines`, seen
/// from surface point P: spot(cone) x doors / d^2. Writes the unit direction to the light to L.
template <typename T>
T spotFalloff(const vec3<T>& P, const vec3<T>& lightPos, const SpotFrame<T>& f, const vec2<T>& cosines,
              const vec4<T>& doors, vec3<T>& L) {
    const vec3<T> toLight = lightPos - P;
    const T dist2 = std::max(glm::dot(toLight, toLight), T(1e-12));
    L = toLight / std::sqrt(dist2);
    T spot = spotCone(cosines, L, f.axis);
    if (spot > T(0)) spot *= barnDoors(f, doors, -L);
    return spot * inverseSquare(dist2);
}

/// The same for a point light: 1/d^2 only (no cone).
template <typename T> T pointFalloff(const vec3<T>& P, const vec3<T>& lightPos, vec3<T>& L) {
    const vec3<T> toLight = lightPos - P;
    const T dist2 = std::max(glm::dot(toLight, toLight), T(1e-12));
    L = toLight / std::sqrt(dist2);
    return inverseSquare(dist2);
}

} // namespace dfb::lightmath
