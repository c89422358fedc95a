#pragma once
// Test support: one light's radiance at one G-buffer sample, in double, from dfb/lightmath (Brdf.h,
// Falloff.h) and the rig's light, as the relight shaders compute it without shadows or cookie:
// f(L, V) N.L x colour x intensity x falloff (docs/lighting.md). The engine tests and
// dfb-fidelity-bench compare the GPU with it.

#include <dfb/lightmath/Brdf.h>
#include <dfb/lightmath/Falloff.h>
#include <dfb/protocol/Rig.h>

#include <glm/glm.hpp>

namespace dfb::test {

inline glm::dvec3 toDouble(const Vec3& v) { return {v[0], v[1], v[2]}; }

/// The G-buffer terms of one sample (DeepBuffer.h), in double.
struct SampleTerms {
    glm::dvec3 P, N, albedo{0.5};
    glm::dvec4 brdf{0, 1, 0, 1}; ///< metallic, roughness, specular, occlusion
    glm::dvec4 sheen{0.0};
    glm::dvec2 coat{0.0};
};

/// Radiance towards V (unit, to the eye) of a spot, point or directional light (not a BendyLight)
/// at the sample, unshadowed.
inline glm::dvec3 cpuShade(const Light& l, const SampleTerms& s, const glm::dvec3& V) {
    namespace lm = dfb::lightmath;
    const lm::SpotFrame<double> frame = lm::spotFrame(toDouble(l.direction));
    glm::dvec3 L;
    double falloff = 1;
    if (l.type == LightType::Directional) {
        L = -frame.axis;
    } else if (l.type == LightType::Point) {
        falloff = lm::pointFalloff(s.P, toDouble(l.position), L);
    } else {
        const glm::dvec2 cone = lm::spotConeCosines(glm::radians(double(l.coneAngleDeg)), glm::radians(double(l.penumbraDeg)));
        const glm::dvec4 doors(lm::barnDoorRadians(double(l.barnDoorsDeg[0])), lm::barnDoorRadians(double(l.barnDoorsDeg[1])),
                               lm::barnDoorRadians(double(l.barnDoorsDeg[2])), lm::barnDoorRadians(double(l.barnDoorsDeg[3])));
        falloff = lm::spotFalloff(s.P, toDouble(l.position), frame, cone, doors, L);
    }
    if (falloff <= 0) return glm::dvec3(0.0);
    return lm::evaluateLayeredBrdfCos(glm::normalize(s.N), L, V, s.albedo, s.brdf, s.sheen, s.coat) * toDouble(l.color) *
           (double(l.intensityCd) * falloff);
}

} // namespace dfb::test
