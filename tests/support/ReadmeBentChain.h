#pragma once
// Test support: the README's bent BendyLight, the tabletop key turned sideways by about 65 degrees
// over its second segment (cone 28 degrees, radii k tan 28 along the straight part, R kappa at
// most ~0.7): one definition for the tests that render it or drag it towards a fold.

#include <dfb/protocol/Rig.h>

#include <glm/glm.hpp>

#include <cmath>

namespace dfb::test {

/// Makes `l` (a spot aimed along its direction) the README's bent BendyLight.
inline void makeReadmeBentChain(Light& l) {
    l.type = LightType::Bendy;
    l.coneAngleDeg = 28.f;
    l.penumbraDeg = 2.f;
    const float tanTheta = std::tan(glm::radians(l.coneAngleDeg));
    l.controlPoints = {{1.5f, 0.f, 0.f}, {3.f, 0.f, 0.f}, {4.2f, 0.f, 0.6f}, {4.8f, 0.f, 1.9f}};
    l.radii = {0.f, 1.5f * tanTheta, 3.f * tanTheta, 3.6f * tanTheta, 4.1f * tanTheta};
    l.colors.assign(5, Vec3{1.f, 1.f, 1.f});
}

} // namespace dfb::test
