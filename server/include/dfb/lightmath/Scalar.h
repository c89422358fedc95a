#pragma once
// The GLSL names the light-math headers share (BendyLight.h, Brdf.h, Falloff.h), templated on the
// scalar (float mirrors the GPU, double is the reference), so that each header and its GLSL mirror
// read line for line the same (STYLE.md, "Shaders and CPU/GPU parity").

#include <glm/glm.hpp>

namespace dfb::lightmath {

template <typename T> using vec3 = glm::vec<3, T, glm::defaultp>;
template <typename T> using vec4 = glm::vec<4, T, glm::defaultp>;
template <typename T> using vec2 = glm::vec<2, T, glm::defaultp>;

/// GLSL's clamp(x, 0, 1).
template <typename T> T saturate(T x) { return x < T(0) ? T(0) : (x > T(1) ? T(1) : x); }

/// GLSL's smoothstep (GLSL 4.50 section 8.3): t = clamp((x - e0) / (e1 - e0), 0, 1), t^2 (3 - 2t).
/// Undefined in GLSL for e0 >= e1; callers keep e0 < e1.
template <typename T> T smoothstep(T e0, T e1, T x) {
    const T t = saturate((x - e0) / (e1 - e0));
    return t * t * (T(3) - T(2) * t);
}

} // namespace dfb::lightmath
