#pragma once
// Indirect editing (paper 000 "BendyLights", section 5 "Indirect Control", eqs. 11-13; issue 17
// points 2 and 3; DESIGN section 7): the user drags a feature of the image (a shadow point, the
// hotspot, a highlight) and these functions return the light that puts the feature there. Pure
// math on a rig Light: no protocol message, no GL. Header-only, double precision.
//
// Notation as in the paper: Pl the light's position (the spotlight S's source, p0 of a BendyLight),
// M the surface point under the pointer at the click, M' (`Mnew`) the one under it now, P the
// pivot (occluder) point, X / N / Vi the surface point, normal and view direction of a highlight,
// Li the light direction at X (towards the light; eq. 9 for a BendyLight).
//
// Rigid modes (empty selection) move the whole light; a BendyLight's control points are stored in
// the light's frame (Rig.h), so they follow a move of the position, and a rotation rotates them
// with the frame (re-expressed in the frame of the new direction, whose roll comes from the
// up-vector rule of lightFrame). Non-rigid modes (paper section 5, last paragraph: "we modify only
// the selected control points") apply the same motion to the selected control points cp[i],
// i = 1..2K (the protocol's indices; cp[0] is the source), and leave the light's position,
// direction and every other control point bit for bit as they were.
//
// Straight lights (spot, point, directional) use the paper's closed forms, which are exact there.
// For a BendyLight the closed form is the starting guess and a small Levenberg-Marquardt solve on
// the motion (3 unknowns: a translation or a rotation vector; central-difference Jacobian) makes
// the *bent* quantity exact: the deformed ray (eq. 7) for shadows and hotspots, the bent direction
// Li (eq. 9, or the exact flow-line tangent when the light says so) for highlights.
// The BendyLight's points are world-space points of the undeformed scene (the paper's M and P are
// "after deformation"; a caller that picked on the deformed geometry maps its hits back first,
// issue 17 point 1).

#include <dfb/core/Result.h>
#include <dfb/lightmath/BendyLight.h>
#include <dfb/lightmath/Falloff.h>
#include <dfb/protocol/Rig.h>
#include <dfb/server/BendyChain.h>

#include <glm/glm.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

namespace dfb::indirect {

using glm::dvec3;

/// The edited light and how the solve went.
struct Edit {
    Light light;
    int iterations = 0;     ///< Levenberg-Marquardt iterations (0: closed form, straight lights)
    double residual = 0.0;  ///< final residual of the solve in double precision (unit-vector difference)
};

/// Control points to move in a non-rigid mode: cp indices 1..2K (cp[0], the source, is not
/// selectable: move the light instead). Empty: the rigid mode.
using Selection = std::vector<int>;

/// Most solver iterations, and the residual (a difference of unit vectors, about an angle in
/// radians) below which it stops and above which the drag is refused as not converged. Accepted:
/// 1e-6 rad, a micrometre at a metre, far under any pixel's footprint; on real picks (float
/// points from the G-buffer) the inverse map's own precision leaves a floor of a few 1e-8, where
/// 1e-8 refused 19 of 20 BendyLight shadow-drag updates (dfb-indirect-bench).
constexpr int MAX_ITERATIONS = 40;
constexpr double CONVERGED = 1e-11;
constexpr double ACCEPTED = 1e-6;

namespace detail {

inline Error invalid(const std::string& light, const std::string& what) {
    return makeError(ErrorCode::InvalidValue, "light '" + light + "': " + what);
}

inline bool finite(const dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

inline dvec3 toD(const Vec3& v) { return dvec3(v[0], v[1], v[2]); }
inline Vec3 toF(const dvec3& v) { return Vec3{float(v.x), float(v.y), float(v.z)}; }

/// Rodrigues: the rotation by |x| radians about x / |x|, applied to v.
inline dvec3 rotateBy(const dvec3& x, const dvec3& v) {
    const double angle = glm::length(x);
    if (!(angle > 0.0)) return v;
    const dvec3 k = x / angle;
    return v * std::cos(angle) + glm::cross(k, v) * std::sin(angle) + k * (glm::dot(k, v) * (1.0 - std::cos(angle)));
}

/// The matrix of a rotation given as a function of vectors.
inline glm::dmat3 rotationMatrix(const dvec3& x) {
    return glm::dmat3(rotateBy(x, dvec3(1, 0, 0)), rotateBy(x, dvec3(0, 1, 0)), rotateBy(x, dvec3(0, 0, 1)));
}

/// The paper's "rotate about v x v' by acos(v . v')" (eqs. 12, 13) as a rotation vector; v, v'
/// unit. Antiparallel vectors turn by pi about any perpendicular axis.
inline dvec3 rotationBetween(const dvec3& v, const dvec3& w) {
    const dvec3 axis = glm::cross(v, w);
    const double s = glm::length(axis), c = glm::dot(v, w);
    const double angle = std::atan2(s, c);
    if (s > 1e-12) return axis * (angle / s);
    if (c > 0.0) return dvec3(0.0);
    const dvec3 perp = glm::normalize(glm::cross(v, std::abs(v.x) < 0.9 ? dvec3(1, 0, 0) : dvec3(0, 1, 0)));
    return perp * angle;
}

/// A light's pose in double precision: world position, unit direction, world control points
/// (cp[0] = position), as chainFromLight would compute them.
struct Pose {
    dvec3 direction{0.0};
    int count = 1;  ///< 2K + 1 points in cp (1 for a light without a chain)
    dvec3 cp[lightmath::MAX_CONTROL_POINTS];
    bool turned = false; ///< the direction changed (a translation keeps the stored frame bit for bit)
};

inline Pose poseOf(const Light& light) {
    Pose pose;
    pose.direction = glm::normalize(toD(light.direction));
    pose.cp[0] = toD(light.position);
    if (light.type == LightType::Bendy) {
        glm::dvec3 uL, vL, wL;
        lightFrame(light, uL, vL, wL);
        pose.count = 2 * light.segments() + 1;
        for (int i = 1; i < pose.count; ++i) {
            const Vec3& a = light.controlPoints[size_t(i - 1)];
            pose.cp[i] = pose.cp[0] + uL * double(a[0]) + vL * double(a[1]) + wL * double(a[2]);
        }
    }
    return pose;
}

/// chainFromLight on a pose (double precision, before rounding to the rig's floats).
inline lightmath::Chain<double> chainOf(const Light& light, const Pose& pose) {
    lightmath::Chain<double> ch;
    ch.segments = light.segments();
    for (int i = 0; i < pose.count; ++i) {
        ch.p[i] = pose.cp[i];
        ch.r[i] = double(light.radii[size_t(i)]);
        ch.c[i] = toD(light.colors[size_t(i)]);
    }
    const auto f = lightmath::spotFrame<double>(pose.direction);
    ch.axisU = f.axis;
    ch.axisV = f.up;
    ch.axisW = f.right;
    ch.tanTheta = std::tan(double(light.coneAngleDeg) * 3.14159265358979323846 / 180.0);
    lightmath::prepareChain(ch);
    return ch;
}

/// Writes a pose into a copy of `light`. Rigid: the position, and when the light turned its
/// direction and every control point (in the frame of the stored direction; a translation leaves
/// the light-frame control points as they were). Non-rigid: only the selected control points.
inline Light lightOf(const Light& light, const Pose& pose, const Selection& selected) {
    Light out = light;
    if (selected.empty()) {
        out.position = toF(pose.cp[0]);
        if (!pose.turned) return out;
        out.direction = toF(glm::normalize(pose.direction));
    }
    if (light.type != LightType::Bendy) return out;
    glm::dvec3 uL, vL, wL;
    lightFrame(out, uL, vL, wL);
    const dvec3 p0 = toD(out.position);
    auto store = [&](int i) {
        const dvec3 d = pose.cp[i] - p0;
        out.controlPoints[size_t(i - 1)] = toF(dvec3(glm::dot(d, uL), glm::dot(d, vL), glm::dot(d, wL)));
    };
    if (selected.empty()) {
        for (int i = 1; i < pose.count; ++i) store(i);
    } else {
        for (int i : selected) store(i);
    }
    return out;
}

/// Moves a pose by `delta`: the whole light, or the selected control points.
inline Pose translated(Pose pose, const dvec3& delta, const Selection& selected) {
    if (selected.empty()) {
        for (int i = 0; i < pose.count; ++i) pose.cp[i] += delta;
    } else {
        for (int i : selected) pose.cp[i] += delta;
    }
    return pose;
}

/// Rotates a pose by the rotation vector `x` about `pivot`: the whole light (its direction too),
/// or the selected control points.
inline Pose rotated(Pose pose, const dvec3& pivot, const dvec3& x, const Selection& selected) {
    if (selected.empty()) {
        pose.direction = rotateBy(x, pose.direction);
        pose.turned = true;
        for (int i = 0; i < pose.count; ++i) pose.cp[i] = pivot + rotateBy(x, pose.cp[i] - pivot);
    } else {
        for (int i : selected) pose.cp[i] = pivot + rotateBy(x, pose.cp[i] - pivot);
    }
    return pose;
}

/// The unit direction from the source to X's deformed point Q' (eqs. 4-7): the straight ray of
/// the spotlight S that the bent ray through X becomes. False where X has no foot.
inline bool beamDirection(const lightmath::Chain<double>& ch, const dvec3& X, dvec3& e,
                          lightmath::TubeCoords<double>* coords = nullptr, double* along = nullptr) {
    const auto c = lightmath::inverseMap(ch, X);
    if (!c.valid) return false;
    const dvec3 d = lightmath::deformedPoint(ch, c) - ch.p[0];
    const double len = glm::length(d);
    if (!(len > 0.0) || !std::isfinite(len)) return false;
    e = d / len;
    if (coords) *coords = c;
    if (along) *along = lightmath::arcLength(ch, c.segment, c.t);
    return true;
}

/// Li at X (eq. 9, or the exact tangent with light.exactDirection); false where X has no foot.
inline bool bentDirection(const Light& light, const lightmath::Chain<double>& ch, const dvec3& X, dvec3& Li,
                          lightmath::TubeCoords<double>* coords = nullptr) {
    const auto c = lightmath::inverseMap(ch, X);
    if (!c.valid) return false;
    Li = lightmath::lightDirection(ch, c, X, light.exactDirection);
    if (coords) *coords = c;
    return finite(Li);
}

/// Levenberg-Marquardt on x in R^3 for residual(x) = 0 (3 components; the residuals here are
/// differences of unit vectors, so J has rank 2 and the damping picks the least motion along the
/// free direction). `residual` returns false where x is outside its domain (a point without a foot):
/// such a step is rejected. `h`: central-difference step. Returns false when the start is outside.
inline bool solve(const std::function<bool(const dvec3&, dvec3&)>& residual, double h, dvec3& x, int& iterations,
                  double& finalResidual) {
    dvec3 r;
    iterations = 0;
    if (!residual(x, r)) return false;
    double cost = glm::dot(r, r);
    double lambda = 1e-6;
    while (std::sqrt(cost) > CONVERGED && iterations < MAX_ITERATIONS) {
        ++iterations;
        glm::dmat3 J(0.0); // columns: d r / d x_j
        bool ok = true;
        for (int j = 0; j < 3 && ok; ++j) {
            dvec3 step(0.0);
            step[j] = h;
            dvec3 rp, rm;
            ok = residual(x + step, rp) && residual(x - step, rm);
            J[j] = (rp - rm) / (2.0 * h);
        }
        if (!ok) break;
        const glm::dmat3 JtJ = glm::transpose(J) * J;
        const dvec3 g = glm::transpose(J) * r;
        const double scale = std::max(JtJ[0][0] + JtJ[1][1] + JtJ[2][2], 1e-300);
        bool improved = false;
        for (int attempt = 0; attempt < 12 && !improved; ++attempt) {
            const dvec3 delta = -glm::inverse(JtJ + glm::dmat3(lambda * scale)) * g;
            dvec3 rn;
            if (finite(delta) && residual(x + delta, rn) && glm::dot(rn, rn) < cost) {
                x += delta;
                r = rn;
                cost = glm::dot(rn, rn);
                lambda = std::max(lambda / 10.0, 1e-12);
                improved = true;
            } else {
                lambda *= 10.0;
            }
        }
        if (!improved) break;
    }
    finalResidual = std::sqrt(cost);
    return true;
}

/// Common checks: a usable light and selection.
inline Status checkLight(const Light& light, const Selection& selected) {
    if (!finite(toD(light.position)) || !finite(toD(light.direction)) || !(glm::length(toD(light.direction)) > 0.0)) {
        return invalid(light.name, "position or direction is not finite, or the direction has zero length");
    }
    if (light.type == LightType::Bendy) {
        const int K = light.segments();
        if (K < 1 || K > lightmath::MAX_SEGMENTS || light.controlPoints.size() != size_t(2 * K) ||
            light.radii.size() != size_t(2 * K + 1) || light.colors.size() != size_t(2 * K + 1)) {
            return invalid(light.name, "the BendyLight's chain is incomplete (2K control points, 2K+1 radii and colours)");
        }
        for (const Vec3& p : light.controlPoints) {
            if (!finite(toD(p))) return invalid(light.name, "a control point is not finite");
        }
    }
    if (selected.empty()) return okStatus();
    if (light.type != LightType::Bendy) {
        return invalid(light.name, "non-rigid drags (selected control points) apply to BendyLights only");
    }
    std::vector<int> seen;
    for (int i : selected) {
        if (i == 0) return invalid(light.name, "cp[0] is the light's source; use the rigid drag to move it");
        if (i < 0 || i > 2 * light.segments()) {
            return invalid(light.name, "selected control point cp[" + std::to_string(i) + "] does not exist (1.." +
                                           std::to_string(2 * light.segments()) + ")");
        }
        if (std::find(seen.begin(), seen.end(), i) != seen.end()) {
            return invalid(light.name, "control point cp[" + std::to_string(i) + "] is selected twice");
        }
        seen.push_back(i);
    }
    return okStatus();
}

inline Result<Edit> finish(const Light& light, const Pose& pose, const Selection& selected, int iterations,
                           double residual, const char* what) {
    if (!(residual <= ACCEPTED)) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "the %s did not converge (residual %.3g after %d iterations)", what, residual,
                      iterations);
        return invalid(light.name, buf);
    }
    Edit e;
    e.light = lightOf(light, pose, selected);
    e.iterations = iterations;
    e.residual = residual;
    return e;
}

} // namespace detail

/// Shadow drag (paper 000 eq. 11): the shadow of the occluder point P falls at M on a receiver;
/// after the drag it falls at M' (`Mnew`).
///  - Spot and point lights: Pl' = P + (P - M') |Pl - P| / |P - M|, the light moved (direction
///    kept), so that Pl', P, M' are collinear with P between, and the light keeps the ratio of its
///    distance to the occluder over the occluder's to the receiver. Control points follow.
///  - Directional lights: the direction becomes normalize(M' - P) (the ray through P hits M').
///  - BendyLights: the light (rigid) or the selected control points (non-rigid) translate so that
///    P and M' lie on one deformed ray from the source (same beam direction of Q', eq. 7: P's
///    shadow falls on M' along the bent ray), M' beyond P; eq. 11 applied to the deformed points
///    Q'(P), Q'(M), Q'(M') gives the first guess; P must stay inside the tube (it occludes).
/// Errors: non-finite input, M == P or M' == P, a point without a foot in the tube, a mode that
/// does not apply (selection on a non-BendyLight), no convergence.
inline Result<Edit> shadowDrag(const Light& light, const dvec3& P, const dvec3& M, const dvec3& Mnew,
                               const Selection& selected = {}) {
    using namespace detail;
    if (auto s = checkLight(light, selected); !s) return s.error();
    if (!finite(P) || !finite(M) || !finite(Mnew)) return invalid(light.name, "shadow drag: a point is not finite");
    const double scale = std::max({1.0, glm::length(P), glm::length(M), glm::length(Mnew), glm::length(toD(light.position))});
    const double tiny = 1e-9 * scale;
    if (!(glm::length(M - P) > tiny) || !(glm::length(Mnew - P) > tiny)) {
        return invalid(light.name, "shadow drag: the shadow point coincides with the occluder point (M == P)");
    }
    const Pose pose = poseOf(light);
    const dvec3 Pl = pose.cp[0];
    if (light.type == LightType::Directional) {
        Pose out = pose;
        out.direction = glm::normalize(Mnew - P);
        out.turned = true;
        return finish(light, out, selected, 0, 0.0, "shadow drag");
    }
    if (light.type != LightType::Bendy) {
        if (!(glm::length(Pl - P) > tiny)) return invalid(light.name, "shadow drag: the occluder point is at the light");
        const dvec3 PlNew = P + (P - Mnew) * (glm::length(Pl - P) / glm::length(P - M)); // eq. 11
        return finish(light, translated(pose, PlNew - Pl, selected), selected, 0, 0.0, "shadow drag");
    }
    // BendyLight: eq. 11 in the deformed space for the first guess.
    const auto ch = chainOf(light, pose);
    auto deformed = [&](const dvec3& X, dvec3& Xd) {
        const auto c = lightmath::inverseMap(ch, X);
        if (!c.valid) return false;
        Xd = lightmath::deformedPoint(ch, c);
        return finite(Xd);
    };
    dvec3 Pd, Md, MnewD;
    if (!deformed(P, Pd) || !deformed(M, Md) || !deformed(Mnew, MnewD)) {
        return invalid(light.name, "shadow drag: a point lies behind the BendyLight's source (no foot in its tube)");
    }
    if (!(glm::length(Pd - Md) > tiny) || !(glm::length(Pl - Pd) > tiny)) {
        return invalid(light.name, "shadow drag: degenerate deformed points (Q'(M) == Q'(P), or P at the source)");
    }
    const dvec3 x0 = Pd + (Pd - MnewD) * (glm::length(Pl - Pd) / glm::length(Pd - Md)) - Pl; // eq. 11, deformed
    // P's and M''s beam directions agree anywhere along their common ray: the residual's Jacobian
    // has a null direction, about the ray d = Q'(P) - Q'(M'), along which an undamped step drifts
    // (a bent light was flung 15 km away, dfb-indirect-bench). Eq. 11 fixes the light's distance
    // along that ray; the solve keeps it and moves only across the ray (y's part along d is
    // projected out, so each step is a 2-D correction of the closed form).
    const dvec3 d = glm::normalize(Pd - MnewD);
    const auto across = [&](const dvec3& y) { return x0 + (y - d * glm::dot(y, d)); };
    dvec3 x(0.0);
    auto residual = [&](const dvec3& y, dvec3& r) {
        const auto moved = chainOf(light, translated(pose, across(y), selected));
        dvec3 eP, eM;
        if (!beamDirection(moved, P, eP) || !beamDirection(moved, Mnew, eM)) return false;
        r = eP - eM;
        return true;
    };
    int iterations = 0;
    double res = 0.0;
    if (!solve(residual, 1e-6 * scale, x, iterations, res)) {
        // The closed form left the tube's domain: start from the point of its plane nearest to
        // where the light is.
        x = -x0;
        if (!solve(residual, 1e-6 * scale, x, iterations, res)) {
            return invalid(light.name, "shadow drag: the occluder or the new shadow point has no foot in the tube");
        }
    }
    const Pose out = translated(pose, across(x), selected);
    const auto moved = chainOf(light, out);
    lightmath::TubeCoords<double> cP;
    double sP = 0.0, sM = 0.0;
    dvec3 e;
    if (!beamDirection(moved, P, e, &cP, &sP) || !beamDirection(moved, Mnew, e, nullptr, &sM) || !cP.inside) {
        return invalid(light.name, "shadow drag: the occluder point P is outside the moved BendyLight's tube");
    }
    if (!(sM > sP)) return invalid(light.name, "shadow drag: the new shadow point M' is not beyond the occluder point");
    return finish(light, out, selected, iterations, res, "shadow drag");
}

/// Hotspot drag (paper 000 eq. 12): the point M of the beam moves to M' (`Mnew`).
///  - Spot lights: the frame turns about v x v' by acos(v . v'), v = (M - Pl)/|M - Pl|,
///    v' = (M' - Pl)/|M' - Pl| (the direction rotates; the position stays).
///  - BendyLights: the whole chain turns about p0 (rigid), or the selected control points do
///    (non-rigid), so that M' takes the place in the beam M had: the beam direction of Q'(M')
///    (eq. 7) after the drag equals that of Q'(M) before, in the light's turned frame (rigid) or
///    its unchanged one (non-rigid); eq. 12's straight rotation is the first guess. A hotspot drag
///    from the beam's centre therefore puts the centre line (v = w = 0) through M'.
/// Errors: point and directional lights (no hotspot), M or M' at the light, non-finite input, a
/// point without a foot in the tube, no convergence.
inline Result<Edit> hotspotDrag(const Light& light, const dvec3& M, const dvec3& Mnew, const Selection& selected = {}) {
    using namespace detail;
    if (auto s = checkLight(light, selected); !s) return s.error();
    if (light.type == LightType::Point || light.type == LightType::Directional) {
        return invalid(light.name, "hotspot drag applies to spot lights and BendyLights (this light has no cone)");
    }
    if (!finite(M) || !finite(Mnew)) return invalid(light.name, "hotspot drag: a point is not finite");
    const Pose pose = poseOf(light);
    const dvec3 Pl = pose.cp[0];
    const double scale = std::max({1.0, glm::length(M), glm::length(Mnew), glm::length(Pl)});
    if (!(glm::length(M - Pl) > 1e-9 * scale) || !(glm::length(Mnew - Pl) > 1e-9 * scale)) {
        return invalid(light.name, "hotspot drag: a target point is at the light's position");
    }
    dvec3 x = rotationBetween(glm::normalize(M - Pl), glm::normalize(Mnew - Pl)); // eq. 12
    if (light.type == LightType::Spot) return finish(light, rotated(pose, Pl, x, selected), selected, 0, 0.0, "hotspot drag");
    const auto ch = chainOf(light, pose);
    dvec3 e0;
    if (!beamDirection(ch, M, e0)) return invalid(light.name, "hotspot drag: M lies behind the BendyLight's source");
    auto residual = [&](const dvec3& rot, dvec3& r) {
        const auto moved = chainOf(light, rotated(pose, Pl, rot, selected));
        dvec3 e;
        if (!beamDirection(moved, Mnew, e)) return false;
        r = e - (selected.empty() ? rotateBy(rot, e0) : e0);
        return true;
    };
    int iterations = 0;
    double res = 0.0;
    if (!solve(residual, 1e-7, x, iterations, res)) {
        x = dvec3(0.0);
        if (!solve(residual, 1e-7, x, iterations, res)) {
            return invalid(light.name, "hotspot drag: M' has no foot in the BendyLight's tube");
        }
    }
    return finish(light, rotated(pose, Pl, x, selected), selected, iterations, res, "hotspot drag");
}

/// Highlight drag (paper 000 eq. 13): a specular highlight at the surface point X (normal N, unit
/// view direction Vi from X towards the eye; none deformed). v' = -Vi + 2 (N . Vi) N, the view
/// direction reflected about N (= GLSL reflect(-Vi, N)), becomes the light direction at X.
///  - Spot and point lights: Pl (and a spot's frame) rotate about X along v x v' by acos(v . v'),
///    v = Li = (Pl - X)/|Pl - X|.
///  - Directional lights: direction = -v'.
///  - BendyLights: v = Li is eq. 9's bent direction at X (lightmath::lightDirection); the whole
///    light (rigid) or the selected control points (non-rigid) rotate about X, solved so that the
///    bent Li after the edit equals v' (for the rigid mode the paper's one rotation is already
///    exact, since eq. 9 turns with a chain turned about X; the solve confirms it in 0-1
///    iterations; non-rigid edits change the bend and need a few). X must stay inside the tube.
/// Errors: N or Vi of zero length or not finite, Vi behind the surface (N . Vi <= 0), X at the
/// light, X without a foot or outside the tube, no convergence.
inline Result<Edit> highlightDrag(const Light& light, const dvec3& X, const dvec3& Nin, const dvec3& Vin,
                                  const Selection& selected = {}) {
    using namespace detail;
    if (auto s = checkLight(light, selected); !s) return s.error();
    if (!finite(X) || !finite(Nin) || !finite(Vin)) return invalid(light.name, "highlight drag: an input is not finite");
    if (!(glm::length(Nin) > 1e-12) || !(glm::length(Vin) > 1e-12)) {
        return invalid(light.name, "highlight drag: the normal or the view direction has zero length");
    }
    const dvec3 N = glm::normalize(Nin), V = glm::normalize(Vin);
    if (!(glm::dot(N, V) > 0.0)) return invalid(light.name, "highlight drag: the surface faces away from the eye (N . V <= 0)");
    const dvec3 target = -V + N * (2.0 * glm::dot(N, V)); // eq. 13, v'
    const Pose pose = poseOf(light);
    if (light.type == LightType::Directional) {
        Pose out = pose;
        out.direction = -target;
        out.turned = true;
        return finish(light, out, selected, 0, 0.0, "highlight drag");
    }
    const dvec3 Pl = pose.cp[0];
    const double scale = std::max({1.0, glm::length(X), glm::length(Pl)});
    if (!(glm::length(Pl - X) > 1e-9 * scale)) return invalid(light.name, "highlight drag: X is at the light's position");
    if (light.type != LightType::Bendy) {
        const dvec3 x = rotationBetween(glm::normalize(Pl - X), target); // eq. 13
        return finish(light, rotated(pose, X, x, selected), selected, 0, 0.0, "highlight drag");
    }
    const auto ch = chainOf(light, pose);
    dvec3 Li;
    lightmath::TubeCoords<double> c;
    if (!bentDirection(light, ch, X, Li, &c) || !c.inside) {
        return invalid(light.name, "highlight drag: X is not lit by the BendyLight (outside its tube or behind its source)");
    }
    dvec3 x = rotationBetween(Li, target); // eq. 13 with eq. 9's Li
    auto residual = [&](const dvec3& rot, dvec3& r) {
        const auto moved = chainOf(light, rotated(pose, X, rot, selected));
        dvec3 L;
        if (!bentDirection(light, moved, X, L)) return false;
        r = L - target;
        return true;
    };
    int iterations = 0;
    double res = 0.0;
    if (!solve(residual, 1e-7, x, iterations, res)) {
        return invalid(light.name, "highlight drag: X has no foot in the edited BendyLight's tube");
    }
    const Pose out = rotated(pose, X, x, selected);
    dvec3 L;
    if (!bentDirection(light, chainOf(light, out), X, L, &c) || !c.inside) {
        return invalid(light.name, "highlight drag: X leaves the BendyLight's tube for the solved rotation");
    }
    return finish(light, out, selected, iterations, res, "highlight drag");
}

/// Physical shadow move (Kasai et al. section 4.2.2, eq. 15): the occluder point S (the first hit
/// of the ray from the light's source to the clicked receiver point C, picked on the geometry the
/// shadow map uses and mapped back for a BendyLight) keeps casting, and its shadow moves from C to
/// C' (`Cnew`): every control point, the source included, rotates about S, cp' = (cp - S) R(theta_S)
/// + S, by the rotation that takes the direction S - C to S - C' (the light's ray through S then
/// ends at C' for a straight light; a BendyLight's bent rays turn with it, as the whole chain and
/// the scene around S are turned alike). Directional lights turn their direction by the same R.
/// Non-rigid: only the selected control points rotate (the paper's mode moves them all).
/// Errors: non-finite input, C or C' at S.
inline Result<Edit> physicalShadowMove(const Light& light, const dvec3& S, const dvec3& C, const dvec3& Cnew,
                                       const Selection& selected = {}) {
    using namespace detail;
    if (auto s = checkLight(light, selected); !s) return s.error();
    if (!finite(S) || !finite(C) || !finite(Cnew)) return invalid(light.name, "physical shadow move: a point is not finite");
    const double scale = std::max({1.0, glm::length(S), glm::length(C), glm::length(Cnew)});
    if (!(glm::length(S - C) > 1e-9 * scale) || !(glm::length(S - Cnew) > 1e-9 * scale)) {
        return invalid(light.name, "physical shadow move: the shadow point is at its occluder point S");
    }
    const dvec3 x = rotationBetween(glm::normalize(S - C), glm::normalize(S - Cnew)); // R(theta_S), eq. 15
    return finish(light, rotated(poseOf(light), S, x, selected), selected, 0, 0.0, "physical shadow move");
}

/// Diffuse move (Kasai et al. section 4.2.2, eq. 16): the diffuse brightness at the clicked point C
/// (normal N) is carried to C' (normal N'): cp' = (cp - C) R(theta_N) + C', R the rotation taking N
/// to N', for every control point (the light direction turns by R too). The light then stands to
/// C' as it stood to C: the same distance and the same angle to the normal, so a point or spot
/// light gives C' the cosine and inverse-square falloff C had (the cone and any occluder may
/// differ). Directional lights turn their direction by R. Non-rigid: only the selected control
/// points move. Errors: non-finite input, a zero-length normal.
inline Result<Edit> diffuseMove(const Light& light, const dvec3& C, const dvec3& Nin, const dvec3& Cnew,
                                const dvec3& NnewIn, const Selection& selected = {}) {
    using namespace detail;
    if (auto s = checkLight(light, selected); !s) return s.error();
    if (!finite(C) || !finite(Cnew) || !finite(Nin) || !finite(NnewIn)) {
        return invalid(light.name, "diffuse move: an input is not finite");
    }
    if (!(glm::length(Nin) > 1e-12) || !(glm::length(NnewIn) > 1e-12)) {
        return invalid(light.name, "diffuse move: a normal has zero length");
    }
    const dvec3 x = rotationBetween(glm::normalize(Nin), glm::normalize(NnewIn)); // R(theta_N), eq. 16
    const Pose moved = rotated(translated(poseOf(light), Cnew - C, selected), Cnew, x, selected);
    return finish(light, moved, selected, 0, 0.0, "diffuse move");
}

} // namespace dfb::indirect
