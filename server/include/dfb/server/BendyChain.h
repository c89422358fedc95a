#pragma once
// From a rig Light (protocol) to the BendyLight math's Chain (lightmath), and the checks that
// warn about chains the model handles badly (paper 000 section 7).

#include <dfb/lightmath/BendyLight.h>
#include <dfb/lightmath/Falloff.h>
#include <dfb/protocol/Rig.h>

#include <string>

namespace dfb {

/// The light's frame (docs/protocol.md): uL = direction, wL = normalize(cross(uL, up)),
/// vL = cross(wL, uL), up = +Y unless uL is within ~8 degrees of vertical, then +X.
/// Inline (lightmath::spotFrame: (axis, up, right) is (uL, vL, wL)) so that header-only users
/// (IndirectEdit.h and its unit test) need no library.
inline void lightFrame(const Light& light, glm::dvec3& uL, glm::dvec3& vL, glm::dvec3& wL) {
    const auto f = lightmath::spotFrame<double>(glm::dvec3(light.direction[0], light.direction[1], light.direction[2]));
    uL = f.axis;
    vL = f.up;
    wL = f.right;
}

/// The prepared chain of a BendyLight (control points converted to world space).
template <typename T> lightmath::Chain<T> chainFromLight(const Light& light) {
    glm::dvec3 uL, vL, wL;
    lightFrame(light, uL, vL, wL);
    lightmath::Chain<T> ch;
    ch.segments = light.segments();
    const glm::dvec3 p0(light.position[0], light.position[1], light.position[2]);
    ch.p[0] = lightmath::vec3<T>(p0);
    for (int i = 1; i <= 2 * ch.segments; ++i) {
        const Vec3& a = light.controlPoints[size_t(i - 1)];
        ch.p[i] = lightmath::vec3<T>(p0 + uL * double(a[0]) + vL * double(a[1]) + wL * double(a[2]));
    }
    for (int i = 0; i <= 2 * ch.segments; ++i) {
        ch.r[i] = T(light.radii[size_t(i)]);
        const Vec3& c = light.colors[size_t(i)];
        ch.c[i] = lightmath::vec3<T>(T(c[0]), T(c[1]), T(c[2]));
    }
    ch.axisU = lightmath::vec3<T>(uL);
    ch.axisV = lightmath::vec3<T>(vL);
    ch.axisW = lightmath::vec3<T>(wL);
    ch.tanTheta = T(std::tan(double(light.coneAngleDeg) * 3.14159265358979323846 / 180.0));
    lightmath::prepareChain(ch);
    return ch;
}

/// Why a BendyLight's chain is doubtful, or "" when it is fine: a segment of zero length or with a
/// cusp (its tangent vanishes), a tube that folds over itself on the inside of a bend (radius times
/// curvature >= 1: points there have several feet), or parts of the chain that come closer than
/// their radii (a self-intersecting tube, paper section 7: the light would reach a point along two
/// paths; the most central one wins). Never fails; costs well under a millisecond.
std::string chainWarning(const Light& light);

} // namespace dfb
