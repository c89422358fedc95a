#pragma once
// From a rig Light (protocol) to the BendyLight math's Chain (lightmath), and the checks that
// warn about chains the model handles badly (paper 000 section 7).

#include <dfb/lightmath/BendyLight.h>
#include <dfb/lightmath/Falloff.h>
#include <dfb/protocol/Rig.h>

#include <cmath>
#include <cstdio>
#include <optional>
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

/// The chain point p[i] (i = 0..2K, p0 the source) nearest to parameter u = k + t of segment k:
/// the page labels the handles p1..p2K, so warnings name the handle to move.
inline int nearestChainPoint(int k, double t) { return 2 * k + int(std::lround(2.0 * t)); }

/// chainWarning on a prepared chain (double precision), with margins: a fold is reported from
/// R kappa >= foldLimit and a self-intersection from distance < apartLimit x (sum of radii);
/// chainWarning's limits are 1 and 1 (where the tube really folds or touches itself). The edit
/// limiter (limitChainEdit) stops short of them with stricter limits. Inline so that header-only
/// users (LocalShadowEdit.h and its unit test) refuse what the server would warn about without
/// the engine library. Messages say what to do, in the page's names of the handles (p1..p2K,
/// r0..r2K), with the numbers after it for the technical reader.
inline std::string chainTrouble(const lightmath::Chain<double>& ch, double foldLimit, double apartLimit) {
    using namespace lightmath;
    char buf[320];
    // Samples along the chain: position, radius, arc length, nearest control point.
    struct S {
        glm::dvec3 p;
        double r, s;
        int point;
    };
    std::vector<S> samples;
    const int PER_SEGMENT = 32;
    for (int k = 0; k < ch.segments; ++k) {
        const double len = arcLength(ch, k, 1.0) - arcLength(ch, k, 0.0);
        if (!(len > 1e-9)) {
            std::snprintf(buf, sizeof buf,
                          "p%d, p%d and p%d are at the same place: move p%d or p%d away (segment %d has zero length)",
                          2 * k, 2 * k + 1, 2 * k + 2, 2 * k + 1, 2 * k + 2, k);
            return buf;
        }
        for (int i = 0; i <= PER_SEGMENT; ++i) {
            const double t = double(i) / PER_SEGMENT;
            const glm::dvec3 d = chainDerivative(ch, k, t);
            const int n = nearestChainPoint(k, t);
            if (glm::length(d) < 1e-6 * len) {
                std::snprintf(buf, sizeof buf,
                              "the chain turns back on itself at p%d: move p%d so that the chain does not double back "
                              "(segment %d has a cusp at u = %.2f)",
                              n, n == 0 ? 1 : n, k, k + t);
                return buf;
            }
            const double kappa = glm::length(glm::cross(d, chainSecondDerivative(ch, k))) / std::pow(glm::length(d), 3.0);
            const double R = chainRadius(ch, k, t);
            if (R * kappa >= foldLimit) {
                std::snprintf(buf, sizeof buf,
                              "the tube is wider than the bend at p%d: make the bend gentler or the radius r%d smaller "
                              "(radius %.3g, the bend's radius of curvature %.3g near u = %.2f)",
                              n, n, R, 1.0 / kappa, k + t);
                return buf;
            }
            samples.push_back({chainPoint(ch, k, t), R, arcLength(ch, k, t), n});
        }
    }
    // Parts of the chain far apart along it but close in space.
    for (size_t i = 0; i < samples.size(); ++i)
        for (size_t j = i + 1; j < samples.size(); ++j) {
            const double along = samples[j].s - samples[i].s;
            const double reach = samples[i].r + samples[j].r;
            if (along <= 2.0 * reach) continue; // neighbours along the chain always overlap
            const double apart = glm::length(samples[j].p - samples[i].p);
            if (apart < apartLimit * reach) {
                std::snprintf(buf, sizeof buf,
                              "the tube runs into itself between p%d and p%d: move those parts of the chain apart or "
                              "make the radii smaller (%.3g apart at arc lengths %.3g and %.3g, radii %.3g + %.3g)",
                              samples[i].point, samples[j].point, apart, samples[i].s, samples[j].s, samples[i].r,
                              samples[j].r);
                return buf;
            }
        }
    return {};
}

/// Why a prepared chain is doubtful, or "" (chainTrouble at the limits where the tube really
/// folds or touches itself).
inline std::string chainWarning(const lightmath::Chain<double>& ch) { return chainTrouble(ch, 1.0, 1.0); }

/// Why a BendyLight's chain is doubtful, or "" when it is fine: a segment of zero length or with a
/// cusp (its tangent vanishes), a tube that folds over itself on the inside of a bend (radius times
/// curvature >= 1: points there have several feet), or parts of the chain that come closer than
/// their radii (a self-intersecting tube, paper section 7: the light would reach a point along two
/// paths; the most central one wins). Never fails; costs well under a millisecond.
std::string chainWarning(const Light& light);

/// The BendyLight or bent area light chain's warning with chainTrouble's margins (see there).
std::string chainWarning(const Light& light, double foldLimit, double apartLimit);

/// Margins of the edit limiter: it stops where R kappa reaches 0.9 or the tube comes within
/// 1.1 x its radii of itself (the local shadow edit's regulariser starts at these onsets too,
/// LocalShadowEdit.h FOLD_ONSET / APART_ONSET are they), so that a limited drag leaves the tube visibly
/// clear of the fold, where the deformation still has one foot per point.
constexpr double LIMIT_FOLD = 0.9;
constexpr double LIMIT_APART = 1.1;

/// An edit of a light limited so that its chain does not fold (limitChainEdit).
struct ChainLimit {
    Light light;          ///< `after` moved back towards `before` until the chain is sound
    double fraction = 0;  ///< how far along the way from `before` to `after` it stopped, [0, 1)
    std::string why;      ///< the warning `after` would have had
};

/// When `after` (an edit of `before`, same name and type, BendyLight or bent area light, the
/// same number of segments) has a chain that folds or runs into itself while `before`'s does
/// not: the light part of the way from `before` to `after` (every chain property that differs
/// moves linearly: position, direction (renormalised), controlPoints, radii, cornerPoints,
/// cornerRadii, coneAngle, size, roll), as far as the chain stays within LIMIT_FOLD /
/// LIMIT_APART (or, when `before` itself is within 1 of those, within chainWarning's limits).
/// The way is scanned in 32 steps, then the last sound step and the first unsound one are
/// bisected. nullopt when nothing needs limiting or the rule does not apply.
std::optional<ChainLimit> limitChainEdit(const Light& before, const Light& after);

} // namespace dfb
