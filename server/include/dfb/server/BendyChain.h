#pragma once
// From a rig Light (protocol) to the BendyLight math's Chain (lightmath), and the checks that
// warn about chains the model handles badly (paper 000 section 7).

#include <dfb/lightmath/BendyLight.h>
#include <dfb/lightmath/Falloff.h>
#include <dfb/protocol/Rig.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

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

/// chainWarning on a prepared chain (double precision): inline so that header-only users
/// (LocalShadowEdit.h and its unit test) refuse what the server would warn about without the
/// engine library. The checks and messages are chainWarning's below.
inline std::string chainWarning(const lightmath::Chain<double>& ch) {
    using namespace lightmath;
    char buf[256];
    // Samples along the chain: position, radius, arc length.
    struct S {
        glm::dvec3 p;
        double r, s;
    };
    std::vector<S> samples;
    const int PER_SEGMENT = 32;
    for (int k = 0; k < ch.segments; ++k) {
        const double len = arcLength(ch, k, 1.0) - arcLength(ch, k, 0.0);
        if (!(len > 1e-9)) {
            std::snprintf(buf, sizeof buf, "segment %d has zero length (control points %d-%d coincide)", k, 2 * k, 2 * k + 2);
            return buf;
        }
        for (int i = 0; i <= PER_SEGMENT; ++i) {
            const double t = double(i) / PER_SEGMENT;
            const glm::dvec3 d = chainDerivative(ch, k, t);
            if (glm::length(d) < 1e-6 * len) {
                std::snprintf(buf, sizeof buf, "segment %d has a cusp at u = %.2f (its direction reverses)", k, k + t);
                return buf;
            }
            const double kappa = glm::length(glm::cross(d, chainSecondDerivative(ch, k))) / std::pow(glm::length(d), 3.0);
            const double R = chainRadius(ch, k, t);
            if (R * kappa >= 1.0) {
                std::snprintf(buf, sizeof buf,
                              "the tube folds over itself inside the bend near u = %.2f (radius %.3g exceeds the "
                              "bend's radius of curvature %.3g): self-intersecting tube",
                              k + t, R, 1.0 / kappa);
                return buf;
            }
            samples.push_back({chainPoint(ch, k, t), R, arcLength(ch, k, t)});
        }
    }
    // Parts of the chain far apart along it but close in space.
    for (size_t i = 0; i < samples.size(); ++i)
        for (size_t j = i + 1; j < samples.size(); ++j) {
            const double along = samples[j].s - samples[i].s;
            const double reach = samples[i].r + samples[j].r;
            if (along <= 2.0 * reach) continue; // neighbours along the chain always overlap
            const double apart = glm::length(samples[j].p - samples[i].p);
            if (apart < reach) {
                std::snprintf(buf, sizeof buf,
                              "the tube intersects itself: the chain at arc length %.3g comes within %.3g of itself at "
                              "%.3g (radii %.3g + %.3g)",
                              samples[i].s, apart, samples[j].s, samples[i].r, samples[j].r);
                return buf;
            }
        }
    return {};
}

/// Why a BendyLight's chain is doubtful, or "" when it is fine: a segment of zero length or with a
/// cusp (its tangent vanishes), a tube that folds over itself on the inside of a bend (radius times
/// curvature >= 1: points there have several feet), or parts of the chain that come closer than
/// their radii (a self-intersecting tube, paper section 7: the light would reach a point along two
/// paths; the most central one wins). Never fails; costs well under a millisecond.
std::string chainWarning(const Light& light);

} // namespace dfb
