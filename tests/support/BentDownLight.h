#pragma once
// Test support: the synthetic bent BendyLight of the local shadow edits' test and benchmark
// (lightmath_local_shadow_test, dfb-local-shadow-bench), written once so that both measure the
// same light.

#include <dfb/protocol/Rig.h>

namespace dfb::test {

/// A horizontal source at (0, 2, 0) shining along +x (frame: uL = x, vL = y, wL = z, so control
/// points read as world offsets), straight for two metres, then bent 90 degrees down onto the
/// ground y = -1, which the straight extension meets at right angles (at t = 1, u = 3); radii near
/// the 10-degree cone's. The bend's R kappa peaks at 0.69 (chainWarning: 1).
inline Light bentDownLight() {
    Light l;
    l.name = "bent";
    l.type = LightType::Bendy;
    l.position = {0.f, 2.f, 0.f};
    l.direction = {1.f, 0.f, 0.f};
    l.coneAngleDeg = 10.f;
    l.controlPoints = {{1.f, 0.f, 0.f}, {2.f, 0.f, 0.f}, {3.f, 0.f, 0.f}, {3.f, -1.f, 0.f}};
    l.radii = {0.f, 0.18f, 0.35f, 0.5f, 0.6f};
    l.colors.assign(5, Vec3{1.f, 1.f, 1.f});
    return l;
}

} // namespace dfb::test
