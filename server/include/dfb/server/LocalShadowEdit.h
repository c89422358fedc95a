#pragma once
// Local shadow move and local shadow scale (Kasai, Dobashi and Yamamoto, "An Intuitive Editing
// System for a Shadow Using BendyLights", IPSJ, in Japanese; section 4.2.1, eqs. 11-14; issue 17
// point 4; DESIGN section 7). BendyLights only; pure math on a rig Light, header-only, double
// precision, as IndirectEdit.h.
//
// The user clicks a shadow point Ct on a receiver; S is the occluder point that casts it (the
// first hit of the bent ray from the source to Ct, the Picker's occluder, mapped back to the
// undeformed scene). Dragging Ct to C't (`CtNew`) asks for the light whose tube gives C't the tube
// coordinates (u, v, w) (u = k + t the chain parameter, v, w eqs. 5-6) that Ct had at the click,
// while S keeps its own (u, v, w): S's shading stays, and S's shadow now falls on C' t (C't shares
// S's (v, w) further along the tube). With primes for the edited light,
//   E = (uc - u'c)^2 + (vc - v'c)^2 + (wc - w'c)^2 + (us - u's)^2 + (vs - v's)^2 + (ws - w's)^2,
// E1 (eq. 11) over the control points' positions (local shadow move: the shadow bends and
// stretches), E2 (eq. 13) over their radii (local shadow scale: the tube widens or narrows at C't,
// so the shadow grows or shrinks about the tube's centre line).
//
// Occluder samples (issue 17 point 8: the occluder's radiance changes by under 1 %): S is one
// point, while the occluder (a vase) spans the part of the tube the edit moves, so keeping S's
// coordinates alone lets the rest of the occluder's shading change (2.6 % median on the tabletop's
// vase). The caller may pass up to LOCAL_MAX_OCCLUDER_SAMPLES more points of the occluder's object
// that the light reaches (Drag.cpp: G-buffer positions of the occluder's lit pixels, chosen once at
// the drag's begin); each keeps its click (u, v, w) as a soft residual. The six residuals of C't
// and S are the hard part: the bound, the refusals and `residual` are about them alone, and the
// samples only choose among the lights that meet them (where the unknowns leave freedom after the
// six: a square or overdetermined problem gives the samples nothing, and the hard part wins). Two
// Levenberg-Marquardt runs do that: (1) the six plus the samples at OCCLUDER_WEIGHT / sqrt(n)
// each (together OCCLUDER_WEIGHT, small against the six so that the compromise stays near the
// hard part's solution set, large against TIKHONOV so that the samples, not the least change,
// pick the point in it), stopped by MINPACK's tests at LOCAL_OCCLUDER_TOL; (2) the six alone from
// there, with the Tikhonov term about run (1)'s result instead of the begin light, so that it
// closes the hard part's last bit (~OCCLUDER_WEIGHT^2 of the samples' residual) by the least
// change and keeps what run (1) gained; it stops at LOCAL_CONVERGED as a plain solve does.
// Samples outside the begin tube (the light does not reach them) are dropped. Without samples
// the solve is run (2) alone from the begin light: the six residuals, as before.
//
// Solver: Eigen's Levenberg-Marquardt (unsupported/Eigen/LevenbergMarquardt, MINPACK's lmder) on
// the six tube residuals plus a regulariser, with a central-difference Jacobian from Eigen's
// NumericalDiff. Not AutoDiff: lightmath's Chain<T> stores glm::vec<3, T>, whose union members
// need a trivially constructible T (AutoDiffScalar holds a derivative vector; the instantiation
// fails to compile), and glm::length / normalize assert an IEEE scalar; the inverse map also
// branches on its roots (Cardano or trigonometric, the most central foot), so its derivative is
// only piecewise defined anyway. The unknowns are x = 1 + (displacement / L), L the chain's arc
// length: NumericalDiff's step is sqrt(epsfcn) |x_j|, so every coordinate gets the same step,
// 1e-6 L (truncation ~1e-12, rounding of the inverse map ~1e-15 / 1e-6).
//
// Regulariser (extra residuals, zero where the chain is fine):
//  - fold: per segment, max over samples of PENALTY_WEIGHT * max(0, R kappa - onset), onset =
//    FOLD_ONSET (0.9) or the begin chain's own value if higher (chainWarning refuses at 1);
//  - self-intersection: PENALTY_WEIGHT * max(0, onset - |p_i - p_j| / (r_i + r_j)) over sample
//    pairs further apart along the chain than twice their radii (chainWarning's pairs), onset =
//    APART_ONSET (1.1) or the begin chain's least ratio if lower (chainWarning refuses below 1);
//  - scale mode: PENALTY_WEIGHT * max(0, -r_i, WAIST_ONSET r_i0 - r_i) / L: radii stay >= 0 (the
//    chain uses max(r_i, 0)) and above WAIST_ONSET of their begin value r_i0 within one drag (a
//    shrink further than that is refused, naming the limit; a second drag shrinks on);
//  - Tikhonov: TIKHONOV * (x_j - 1), the displacement from the begin light in units of L (in run
//    (2) after occluder samples: from run (1)'s result), so that underdetermined selections
//    (every control point: 3 (2K + 1) unknowns for 6 residuals) take the least change. Its pull leaves about TIKHONOV^2 |x - 1| / sigma(J) <= 1e-8 in the tube
//    residuals (|x - 1| < 1, sigma(J) ~ 1), a hundredth of the bound.
//
// Bounds: the solve is accepted when the tube-coordinate residual |r| = sqrt(E) is at most
// LOCAL_ACCEPTED = ACCEPTED (1e-6; v, w are in units of the radius and u in segments, so 1e-6 is
// about a micrometre on a metre-sized tube, far under a pixel). The scale mode cannot change a
// point's foot (radii do not move the centre line): C't's u'c and the direction of (v'c, w'c) are
// fixed by the drag, and only the radial part is reachable. Its bound applies to that part
// (`Outcome::reachable`: S's residual and |(v'c, w'c)| - (vc, wc) . d, d the unit direction of
// (v'c, w'c)); `residual` reports the whole sqrt(E2). A result that chainWarning flags, or whose
// S falls outside the tube, is refused too; a refused edit changes nothing (the caller keeps its
// light).
//
// Selections: control-point indices 1..2K as in IndirectEdit.h, each once. Empty selection: the
// paper's mode, every control point *including the source cp0* (the light's position; its
// direction is kept) for the move, every radius r[0..2K] for the scale. cp[0] cannot be selected
// alone (0 in a selection is an error): moving the source is the whole-chain mode.
//
// paper::localShadowEdit is the paper's own method (finite-difference steepest descent, eqs. 12
// and 14: step D, coefficient alpha, a fixed iteration cap), kept as the baseline that
// dfb-local-shadow-bench compares with; the server does not use it.

#include <dfb/server/BendyChain.h>
#include <dfb/server/IndirectEdit.h>

#include <Eigen/Core>
#include <unsupported/Eigen/LevenbergMarquardt>
#include <unsupported/Eigen/NumericalDiff>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

namespace dfb::indirect {

/// Levenberg-Marquardt iterations (Jacobians) at most per solve; a drag update converges in 3-5
/// (dfb-local-shadow-bench), the cap only ends hopeless solves.
constexpr int LOCAL_MAX_ITERATIONS = 50;
/// Largest accepted tube-coordinate residual sqrt(E) (see the file comment), and the residual at
/// which the solve stops early (a thousandth of the bound: rounding the result to the rig's floats
/// costs more, ~1e-7).
constexpr double LOCAL_ACCEPTED = ACCEPTED;
constexpr double LOCAL_CONVERGED = 1e-3 * LOCAL_ACCEPTED;
/// Onsets of the regulariser: R kappa where the fold penalty starts (chainWarning: 1), and the
/// distance over the sum of radii below which the self-intersection penalty starts (chainWarning: 1).
/// The edit limiter's margins (BendyChain.h): one pair of numbers for both.
constexpr double FOLD_ONSET = LIMIT_FOLD;
constexpr double APART_ONSET = LIMIT_APART;
/// Scale mode: a radius under this fraction of its begin value is penalised like a fold (a
/// waist). The occluder samples alone would pinch the radius between S and C't towards zero to
/// keep their coordinates while the radii beyond it grow (dfb-indirect-bench, 960x540, a 40-px
/// drag: r2 1.0 -> 0.09), a tube whose eq. 7 stretches the deformed casters by R0 / R: the
/// tessellation hit its work bound and frames took 0.27 s. At 0.5 the pinch went but a narrowing
/// past the last point still stretched the casters (0.23 s); at 0.75, 39 ms. A shadow shrinks by
/// at most about a quarter per drag (LocalShadowScale.AWaistIsRefusedNamingTheLimit).
constexpr double WAIST_ONSET = 0.75;
/// Weight of the penalties against the tube residuals (both dimensionless): a fold of 0.01 past
/// the onset costs as much as a 0.01-radius miss, so the solve stops short of folding.
constexpr double PENALTY_WEIGHT = 1.0;
/// Weight of the displacement from the begin light, in units of the chain's length.
constexpr double TIKHONOV = 1e-4;
static_assert(TIKHONOV * TIKHONOV <= 1e-2 * LOCAL_ACCEPTED, "the Tikhonov pull must stay far under the bound");
/// NumericalDiff's epsfcn: steps of sqrt(1e-12) = 1e-6 in x, i.e. 1e-6 L in the world.
constexpr double LOCAL_EPSFCN = 1e-12;
/// Occluder samples at most per solve (see the file comment). Each adds three residuals and an
/// inverse map per function evaluation (2n + 1 evaluations per iteration, n unknowns), so the
/// bound caps the cost of an update; 32 points cover an object's lit side at a few pixels'
/// spacing at 320x180, finer than the light's shading varies across it.
constexpr int LOCAL_MAX_OCCLUDER_SAMPLES = 32;
/// The samples' weight, all together, against the six hard residuals (weight 1). The hard part's
/// share of the compromise of run (1) is ~OCCLUDER_WEIGHT^2 times the samples' residual (~1e-4 x
/// 0.1), which run (2) closes; TIKHONOV^2 / OCCLUDER_WEIGHT^2 = 1e-4: the samples choose.
constexpr double OCCLUDER_WEIGHT = 1e-2;
static_assert(TIKHONOV <= 1e-2 * OCCLUDER_WEIGHT, "the samples, not the least change, must choose the light");
/// MINPACK's ftol and xtol for run (1): relative changes of the compromise below 1e-6 do not show
/// in the image (the samples' residual is ~1e-2, their radiance follows it to first order).
constexpr double LOCAL_OCCLUDER_TOL = 1e-6;
/// Iterations at most of run (1); run (2) gets the rest of LOCAL_MAX_ITERATIONS.
constexpr int LOCAL_OCCLUDER_ITERATIONS = 30;
static_assert(LOCAL_OCCLUDER_ITERATIONS < LOCAL_MAX_ITERATIONS, "run (2) needs iterations of its own");

namespace local {

using lightmath::Chain;

enum class Mode { Move, Scale };

inline const char* modeName(Mode m) { return m == Mode::Move ? "local shadow move" : "local shadow scale"; }

/// A solve's result before it becomes an Edit: the (rounded) light, the solver's iterations (both
/// runs), the tube residual sqrt(E) of C't and S in double precision, the part the unknowns can
/// reach (equal to residual for the move), the occluder samples' root-mean-square (u, v, w)
/// residual (0 without samples; not judged) and why it was refused ("" when accepted).
struct Outcome {
    Light light;
    int iterations = 0;
    double residual = 0.0;
    double reachable = 0.0;
    double occluder = 0.0;
    int samples = 0; ///< occluder samples used (inside the begin tube)
    std::string refused;
};

/// (u, v, w) of X, u = k + t; false without a foot.
inline bool coordsOf(const Chain<double>& ch, const dvec3& X, dvec3& uvw, bool* inside = nullptr) {
    const auto c = lightmath::inverseMap(ch, X);
    if (!c.valid) return false;
    uvw = dvec3(double(c.segment) + c.t, c.v, c.w);
    if (inside) *inside = c.inside;
    return std::isfinite(uvw.x) && std::isfinite(uvw.y) && std::isfinite(uvw.z);
}

/// The chain's conditions that chainWarning tests, as numbers: the largest R kappa per segment,
/// and the least distance over the sum of radii among far-apart sample pairs (inf when none).
/// 12 samples per segment (chainWarning: 32); the onsets' margins cover the difference.
struct Shape {
    double foldPerSegment[lightmath::MAX_SEGMENTS] = {};
    double apart = std::numeric_limits<double>::infinity();
};

inline Shape shapeOf(const Chain<double>& ch) {
    constexpr int PER_SEGMENT = 12;
    Shape out;
    dvec3 p[lightmath::MAX_SEGMENTS * (PER_SEGMENT + 1)];
    double r[lightmath::MAX_SEGMENTS * (PER_SEGMENT + 1)], s[lightmath::MAX_SEGMENTS * (PER_SEGMENT + 1)];
    int n = 0;
    for (int k = 0; k < ch.segments; ++k) {
        const dvec3 dd = lightmath::chainSecondDerivative(ch, k);
        double worst = 0.0;
        for (int i = 0; i <= PER_SEGMENT; ++i) {
            const double t = double(i) / PER_SEGMENT;
            const dvec3 d = lightmath::chainDerivative(ch, k, t);
            const double len = glm::length(d);
            const double R = lightmath::chainRadius(ch, k, t);
            // A vanishing tangent (a cusp) is an infinite curvature: capped, so the residual stays finite.
            const double rk = len > 1e-12 ? R * glm::length(glm::cross(d, dd)) / (len * len * len) : 1e3;
            worst = std::max(worst, std::min(rk, 1e3));
            p[n] = lightmath::chainPoint(ch, k, t);
            r[n] = R;
            s[n] = lightmath::arcLength(ch, k, t);
            ++n;
        }
        out.foldPerSegment[k] = worst;
    }
    for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j) {
            const double reach = r[i] + r[j];
            if (!(reach > 0.0) || s[j] - s[i] <= 2.0 * reach) continue;
            out.apart = std::min(out.apart, glm::length(p[j] - p[i]) / reach);
        }
    return out;
}

/// One edit's problem: the begin chain, the unknowns and the targets.
struct Problem {
    Light light;
    Mode mode = Mode::Move;
    std::vector<int> vars;   ///< control points (move) or radii (scale) that vary
    Chain<double> base;      ///< the begin light's chain, prepared
    dvec3 S{0.0}, CtNew{0.0};
    dvec3 targetS{0.0}, targetC{0.0}; ///< (u, v, w) of S and Ct at the click
    std::vector<dvec3> samples;       ///< occluder samples inside the begin tube
    std::vector<dvec3> targetSamples; ///< their (u, v, w) at the click
    double sampleWeight = 0.0;        ///< per residual: OCCLUDER_WEIGHT / sqrt(samples.size())
    std::vector<double> anchor;       ///< the Tikhonov term's centre (empty: x = 1, the begin light)
    double L = 1.0;          ///< the begin chain's arc length, the unit of the unknowns
    double foldOnset[lightmath::MAX_SEGMENTS] = {};
    double apartOnset = APART_ONSET;

    int unknowns() const { return mode == Mode::Move ? 3 * int(vars.size()) : int(vars.size()); }
    int residuals() const {
        return 6 + 3 * int(samples.size()) + base.segments + 1 + (mode == Mode::Scale ? unknowns() : 0) + unknowns();
    }

    /// The chain for unknowns x (x = 1: the begin chain). Scale: radii clamped at 0.
    Chain<double> chainAt(const double* x) const {
        Chain<double> ch = base;
        for (size_t j = 0; j < vars.size(); ++j) {
            const int i = vars[j];
            if (mode == Mode::Move) {
                ch.p[i] = base.p[i] + dvec3(x[3 * j] - 1.0, x[3 * j + 1] - 1.0, x[3 * j + 2] - 1.0) * L;
            } else {
                ch.r[i] = std::max(0.0, base.r[i] + (x[j] - 1.0) * L);
            }
        }
        lightmath::prepareChain(ch);
        return ch;
    }

    /// The six tube residuals (E = their squared sum); false where S or C't has no foot.
    bool tube(const Chain<double>& ch, double r[6]) const {
        dvec3 c, s;
        if (!coordsOf(ch, CtNew, c) || !coordsOf(ch, S, s)) return false;
        const dvec3 dc = c - targetC, ds = s - targetS;
        for (int k = 0; k < 3; ++k) {
            r[k] = dc[k];
            r[3 + k] = ds[k];
        }
        return true;
    }

    /// The occluder samples' root-mean-square (u, v, w) residual (0 without; inf where one has no
    /// foot).
    double occluderResidual(const Chain<double>& ch) const {
        if (samples.empty()) return 0.0;
        double sum = 0.0;
        for (size_t i = 0; i < samples.size(); ++i) {
            dvec3 c;
            if (!coordsOf(ch, samples[i], c)) return std::numeric_limits<double>::infinity();
            const dvec3 d = c - targetSamples[i];
            sum += glm::dot(d, d);
        }
        return std::sqrt(sum / double(samples.size()));
    }

    /// The residual's part the unknowns can reach (see the file comment): all of it for the move;
    /// for the scale, S's residual and the radial part of C't's.
    double reachable(const Chain<double>& ch) const {
        double r[6];
        if (!tube(ch, r)) return std::numeric_limits<double>::infinity();
        double sum = r[3] * r[3] + r[4] * r[4] + r[5] * r[5];
        if (mode == Mode::Move) return std::sqrt(sum + r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
        const double v = r[1] + targetC.y, w = r[2] + targetC.z, rho = std::hypot(v, w);
        if (!(rho > 0.0)) return std::sqrt(sum + targetC.y * targetC.y + targetC.z * targetC.z);
        const double radial = rho - (targetC.y * v + targetC.z * w) / rho;
        return std::sqrt(sum + radial * radial);
    }
};

/// Eigen's functor: residuals of Problem at x. A point without a foot gets large tube residuals,
/// so that Levenberg-Marquardt rejects the step and shortens the next one.
struct Functor : Eigen::DenseFunctor<double> {
    const Problem* problem;
    explicit Functor(const Problem& p) : Eigen::DenseFunctor<double>(p.unknowns(), p.residuals()), problem(&p) {}

    int operator()(const Eigen::VectorXd& x, Eigen::VectorXd& f) const {
        const Problem& p = *problem;
        const Chain<double> ch = p.chainAt(x.data());
        double r[6];
        if (!p.tube(ch, r)) std::fill(r, r + 6, 1e3);
        int m = 0;
        for (double v : r) f[m++] = v;
        // The occluder samples after the six (the stopping test reads the head).
        for (size_t i = 0; i < p.samples.size(); ++i) {
            dvec3 c;
            const dvec3 d = coordsOf(ch, p.samples[i], c) ? c - p.targetSamples[i] : dvec3(1e3);
            for (int k = 0; k < 3; ++k) f[m++] = p.sampleWeight * d[k];
        }
        const Shape shape = shapeOf(ch);
        for (int k = 0; k < ch.segments; ++k) {
            f[m++] = PENALTY_WEIGHT * std::max(0.0, shape.foldPerSegment[k] - p.foldOnset[k]);
        }
        f[m++] = PENALTY_WEIGHT * std::max(0.0, p.apartOnset - shape.apart);
        const int n = p.unknowns();
        if (p.mode == Mode::Scale) {
            for (int j = 0; j < n; ++j) {
                const double r0 = p.base.r[p.vars[size_t(j)]], rj = r0 + (x[j] - 1.0) * p.L;
                // Below zero, or a waist: under WAIST_ONSET of its begin value (relative to L).
                f[m++] = PENALTY_WEIGHT * std::max({0.0, -rj, WAIST_ONSET * r0 - rj}) / p.L;
            }
        }
        for (int j = 0; j < n; ++j) f[m++] = TIKHONOV * (x[j] - (p.anchor.empty() ? 1.0 : p.anchor[size_t(j)]));
        return 0;
    }
};

/// Checks the input and builds the problem. Errors name the light and the mode.
inline Status prepare(const Light& light, const dvec3& S, const dvec3& Ct, const dvec3& CtNew,
                      const Selection& selected, Mode mode, Problem& out,
                      const std::vector<dvec3>& occluderSamples = {}) {
    using namespace detail;
    const std::string what = modeName(mode);
    if (light.type != LightType::Bendy) {
        static const char* const TYPES[] = {"a spot light", "a BendyLight", "a directional light", "a point light"};
        return invalid(light.name, what + " applies to BendyLights only (this is " + TYPES[int(light.type)] + ")");
    }
    if (auto s = checkLight(light, {}); !s) {
        const std::string prefix = "light '" + light.name + "': ", message = s.error().message;
        return invalid(light.name, what + ": " + (message.rfind(prefix, 0) == 0 ? message.substr(prefix.size()) : message));
    }
    const int K = light.segments();
    std::vector<int> vars;
    for (int i : selected) {
        if (i == 0) {
            return invalid(light.name, what + ": cp[0] is the light's source; it varies only with the empty selection "
                                              "(every control point)");
        }
        if (i < 0 || i > 2 * K) {
            return invalid(light.name, what + ": selected control point cp[" + std::to_string(i) + "] does not exist (1.." +
                                           std::to_string(2 * K) + ")");
        }
        if (std::find(vars.begin(), vars.end(), i) != vars.end()) {
            return invalid(light.name, what + ": control point cp[" + std::to_string(i) + "] is selected twice");
        }
        vars.push_back(i);
    }
    if (vars.empty()) {
        for (int i = 0; i <= 2 * K; ++i) vars.push_back(i);
    }
    for (float r : light.radii) {
        if (!std::isfinite(r) || r < 0.f) return invalid(light.name, what + ": a radius is negative or not finite");
    }
    if (!finite(S) || !finite(Ct) || !finite(CtNew)) return invalid(light.name, what + ": a point is not finite");
    if (occluderSamples.size() > size_t(LOCAL_MAX_OCCLUDER_SAMPLES)) {
        return invalid(light.name, what + ": " + std::to_string(occluderSamples.size()) + " occluder samples, more than " +
                                       std::to_string(LOCAL_MAX_OCCLUDER_SAMPLES));
    }
    for (const dvec3& X : occluderSamples) {
        if (!finite(X)) return invalid(light.name, what + ": an occluder sample is not finite");
    }
    Problem p;
    p.light = light;
    p.mode = mode;
    p.vars = vars;
    p.base = chainOf(light, poseOf(light));
    p.S = S;
    p.CtNew = CtNew;
    p.L = std::max(p.base.arcStart[K], 1e-6);
    bool inside = false;
    if (!coordsOf(p.base, S, p.targetS, &inside) || !inside) {
        return invalid(light.name, what + ": the occluder point S is outside the BendyLight's tube (it casts no shadow "
                                          "of this light)");
    }
    if (!coordsOf(p.base, Ct, p.targetC, &inside) || !inside) {
        return invalid(light.name, what + ": the clicked shadow point Ct is outside the BendyLight's tube");
    }
    dvec3 c;
    if (!coordsOf(p.base, CtNew, c)) {
        return invalid(light.name, what + ": the new shadow point C't has no foot in the tube (behind the source)");
    }
    if (!(p.targetS.x < p.targetC.x)) {
        return invalid(light.name, what + ": S is not between the source and Ct along the tube (u_S >= u_Ct)");
    }
    for (const dvec3& X : occluderSamples) {
        dvec3 uvw;
        if (!coordsOf(p.base, X, uvw, &inside) || !inside) continue; // unlit: nothing to keep
        p.samples.push_back(X);
        p.targetSamples.push_back(uvw);
    }
    if (!p.samples.empty()) p.sampleWeight = OCCLUDER_WEIGHT / std::sqrt(double(p.samples.size()));
    const Shape begin = shapeOf(p.base);
    for (int k = 0; k < K; ++k) p.foldOnset[k] = std::max(FOLD_ONSET, begin.foldPerSegment[k]);
    p.apartOnset = std::min(APART_ONSET, begin.apart);
    out = std::move(p);
    return okStatus();
}

/// The rig light for unknowns x: moved control points re-expressed in the light's frame (a moved
/// source moves the position and every stored offset; the direction is kept), or the new radii.
inline Light lightAt(const Problem& p, const double* x) {
    const Chain<double> ch = p.chainAt(x);
    Light out = p.light;
    if (p.mode == Mode::Scale) {
        for (int i : p.vars) out.radii[size_t(i)] = float(ch.r[i]);
        return out;
    }
    detail::Pose pose = detail::poseOf(p.light);
    for (int i = 0; i < pose.count; ++i) pose.cp[i] = ch.p[i];
    Selection store;
    if (std::find(p.vars.begin(), p.vars.end(), 0) != p.vars.end()) {
        out.position = detail::toF(ch.p[0]);
        for (int i = 1; i < pose.count; ++i) store.push_back(i);
    } else {
        store = p.vars;
    }
    return detail::lightOf(out, pose, store);
}

/// Scale mode: the least ratio of a varied radius to its begin value (1 where none was positive).
inline double narrowest(const Problem& p, const Chain<double>& ch) {
    double least = 1.0;
    for (int i : p.vars)
        if (p.base.r[i] > 0.0) least = std::min(least, ch.r[i] / p.base.r[i]);
    return least;
}

/// Judges a solution: the bound, the tube around S, chainWarning; fills the outcome.
inline Outcome judge(const Problem& p, const double* x, int iterations) {
    Outcome o;
    o.iterations = iterations;
    const Chain<double> ch = p.chainAt(x);
    double r[6];
    o.residual = p.tube(ch, r) ? std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3] + r[4] * r[4] + r[5] * r[5])
                               : std::numeric_limits<double>::infinity();
    o.reachable = p.reachable(ch);
    o.occluder = p.occluderResidual(ch);
    o.samples = int(p.samples.size());
    o.light = lightAt(p, x);
    char buf[320];
    const char* what = modeName(p.mode);
    if (!(o.reachable <= LOCAL_ACCEPTED)) {
        const Shape shape = shapeOf(ch);
        double fold = 0.0, foldOnset = 0.0;
        for (int k = 0; k < ch.segments; ++k) {
            if (shape.foldPerSegment[k] - p.foldOnset[k] > fold) {
                fold = shape.foldPerSegment[k] - p.foldOnset[k];
                foldOnset = p.foldOnset[k];
            }
        }
        if (fold > 0.0) {
            std::snprintf(buf, sizeof buf,
                          "%s: the drag would fold the tube (radius x curvature %.3f at the best compromise; the "
                          "regulariser starts at %.2f, the tube folds at 1); residual %.3g after %d iterations",
                          what, foldOnset + fold, foldOnset, o.reachable, iterations);
        } else if (double least = p.mode == Mode::Scale ? narrowest(p, ch) : 1.0; least < WAIST_ONSET) {
            std::snprintf(buf, sizeof buf,
                          "%s: the drag would narrow the tube to %.0f %% of a radius in one drag (the regulariser "
                          "starts at %.0f %%): release and drag again to shrink it further; residual %.3g after %d "
                          "iterations",
                          what, 100.0 * least, 100.0 * WAIST_ONSET, o.reachable, iterations);
        } else if (shape.apart < p.apartOnset) {
            std::snprintf(buf, sizeof buf,
                          "%s: the drag would make the tube intersect itself (parts of the chain %.3f of their radii "
                          "apart at the best compromise; they meet at 1); residual %.3g after %d iterations",
                          what, shape.apart, o.reachable, iterations);
        } else {
            std::snprintf(buf, sizeof buf,
                          "%s: no solution within the bound (residual %.3g after %d iterations, bound %.0e): the "
                          "selected %s cannot reach the target, or the solver stopped short",
                          what, o.reachable, iterations, LOCAL_ACCEPTED,
                          p.mode == Mode::Move ? "control points" : "radii");
        }
        o.refused = buf;
        return o;
    }
    const Chain<double> rounded = chainFromLight<double>(o.light);
    const std::string warning = chainWarning(rounded);
    if (!warning.empty()) {
        o.refused = std::string(what) + ": the solved chain is refused: " + warning;
        return o;
    }
    dvec3 s;
    bool inside = false;
    if (!coordsOf(rounded, p.S, s, &inside) || !inside) {
        o.refused = std::string(what) + ": the occluder point S leaves the solved tube";
    }
    return o;
}

/// One Levenberg-Marquardt run on p from x (updated), at most maxIterations Jacobians; with
/// untilHard it also stops once the six tube residuals are converged, else MINPACK's tests at
/// LOCAL_OCCLUDER_TOL end it. Returns the iterations taken.
inline int runLm(const Problem& p, Eigen::VectorXd& x, int maxIterations, bool untilHard) {
    Functor f(p);
    Eigen::NumericalDiff<Functor, Eigen::Central> diff(f, LOCAL_EPSFCN);
    Eigen::LevenbergMarquardt<Eigen::NumericalDiff<Functor, Eigen::Central>> lm(diff);
    lm.setMaxfev(maxIterations * (2 * p.unknowns() + 4));
    if (!untilHard) {
        lm.setFtol(LOCAL_OCCLUDER_TOL);
        lm.setXtol(LOCAL_OCCLUDER_TOL);
    }
    auto status = lm.minimizeInit(x);
    int iterations = 0;
    if (status == Eigen::LevenbergMarquardtSpace::ImproperInputParameters) return 0;
    if (untilHard && lm.fvec().head<6>().norm() <= LOCAL_CONVERGED) return 0;
    do {
        status = lm.minimizeOneStep(x);
        ++iterations;
        // MINPACK's own tests are relative to the whole residual, Tikhonov and penalties
        // included; where a penalty's hinge is active at the solution they can take many
        // more steps for nothing the user sees. Stop once the tube residual is converged.
    } while (status == Eigen::LevenbergMarquardtSpace::Running && iterations < maxIterations &&
             (!untilHard || lm.fvec().head<6>().norm() > LOCAL_CONVERGED));
    return iterations;
}

/// Levenberg-Marquardt from the begin light (x = 1), at most LOCAL_MAX_ITERATIONS Jacobians in
/// all: with occluder samples runs (1) and (2) of the file comment, without run (2) alone.
inline Outcome solve(const Problem& p) {
    Eigen::VectorXd x = Eigen::VectorXd::Ones(p.unknowns());
    int iterations = 0;
    if (p.samples.empty()) {
        iterations = runLm(p, x, LOCAL_MAX_ITERATIONS, true);
    } else {
        iterations = runLm(p, x, LOCAL_OCCLUDER_ITERATIONS, false);
        Problem hard = p;
        hard.samples.clear();
        hard.targetSamples.clear();
        hard.anchor.assign(x.data(), x.data() + x.size());
        iterations += runLm(hard, x, LOCAL_MAX_ITERATIONS - iterations, true);
    }
    return judge(p, x.data(), iterations);
}

inline Result<Edit> toEdit(const Light& light, const Outcome& o) {
    if (!o.refused.empty()) return detail::invalid(light.name, o.refused);
    Edit e;
    e.light = o.light;
    e.iterations = o.iterations;
    e.residual = o.residual;
    return e;
}

} // namespace local

/// Local shadow move (Kasai et al. section 4.2.1, E1 of eq. 11): the control points move so that
/// the dragged shadow point C't (`CtNew`) takes the tube coordinates (u, v, w) Ct had at the click
/// and the occluder point S keeps its own; S's shadow then falls on C't. `selected`: cp indices
/// 1..2K that move (3 unknowns each); empty: every control point, the source cp0 (the light's
/// position) included, as in the paper. S, Ct, C't: world points of the undeformed scene.
/// `occluderSamples`: at most LOCAL_MAX_OCCLUDER_SAMPLES more points of the occluder (world, the
/// undeformed scene) whose (u, v, w) are kept too, softly (see the file comment; those outside the
/// begin tube are dropped); empty: S alone, the paper's E1.
/// Returns the light, Levenberg-Marquardt's iterations (both runs) and the residual sqrt(E1) of
/// C't and S.
/// Errors (InvalidValue, naming the light and the mode): not a BendyLight, an incomplete chain, a
/// selection with 0, an index past 2K or one twice, non-finite points, S or Ct outside the tube,
/// C't without a foot, S not before Ct along the tube, more than LOCAL_MAX_OCCLUDER_SAMPLES
/// occluder samples or a non-finite one; refused solves: residual above
/// LOCAL_ACCEPTED (the message says whether folding or self-intersection held it back), a result
/// chainWarning flags, S outside the solved tube.
inline Result<Edit> localShadowMove(const Light& light, const dvec3& S, const dvec3& Ct, const dvec3& CtNew,
                                    const Selection& selected, const std::vector<dvec3>& occluderSamples) {
    local::Problem p;
    if (auto s = local::prepare(light, S, Ct, CtNew, selected, local::Mode::Move, p, occluderSamples); !s) return s.error();
    return local::toEdit(light, local::solve(p));
}

/// The same without occluder samples (S alone, the paper's E1).
inline Result<Edit> localShadowMove(const Light& light, const dvec3& S, const dvec3& Ct, const dvec3& CtNew,
                                    const Selection& selected = {}) {
    return localShadowMove(light, S, Ct, CtNew, selected, std::vector<dvec3>{});
}

/// Local shadow scale (Kasai et al. section 4.2.1, E2 of eq. 13): as localShadowMove, but the
/// unknowns are the radii r[i] of the selected control points (empty: every radius r[0..2K]),
/// kept >= 0; the centre line does not move. Dragging Ct away from the tube's centre line widens
/// the tube there (S's shadow grows), towards it narrows it. Only the radial part of the drag is
/// reachable (see the file comment): the bound applies to it, `residual` is the whole sqrt(E2).
/// `occluderSamples` as localShadowMove's. Errors as localShadowMove.
inline Result<Edit> localShadowScale(const Light& light, const dvec3& S, const dvec3& Ct, const dvec3& CtNew,
                                     const Selection& selected, const std::vector<dvec3>& occluderSamples) {
    local::Problem p;
    if (auto s = local::prepare(light, S, Ct, CtNew, selected, local::Mode::Scale, p, occluderSamples); !s) return s.error();
    return local::toEdit(light, local::solve(p));
}

/// The same without occluder samples (S alone, the paper's E2).
inline Result<Edit> localShadowScale(const Light& light, const dvec3& S, const dvec3& Ct, const dvec3& CtNew,
                                     const Selection& selected = {}) {
    return localShadowScale(light, S, Ct, CtNew, selected, std::vector<dvec3>{});
}

/// The paper's own solver, the baseline of dfb-local-shadow-bench (not used by the server):
/// steepest descent with forward differences, eqs. 12 and 14, on E alone (no regulariser, no
/// occluder samples: the paper keeps S's coordinates only),
///   x(t + 1) = x(t) - alpha (E(x + D e_j) - E(x)) / D  for every unknown at once,
/// from the click's values, for at most `maxIterations` steps (or until sqrt(E) <= CONVERGED).
/// The paper gives no values for D and alpha; here D = stepD L and alpha = alphaL2 L^2 (L the
/// chain's length; x in world units), alpha chosen stable on dfb-local-shadow-bench's drags.
/// Radii are clamped at 0. The result is judged as the LM solve's (bound, chainWarning).
namespace paper {

struct Options {
    double stepD = 1e-7;
    double alphaL2 = 0.003;
    int maxIterations = 200;
};

inline local::Outcome steepestDescent(const local::Problem& p, const Options& opt) {
    const int n = p.unknowns();
    auto energy = [&](const std::vector<double>& x) {
        double r[6];
        if (!p.tube(p.chainAt(x.data()), r)) return std::numeric_limits<double>::infinity();
        double e = 0.0;
        for (double v : r) e += v * v;
        return e;
    };
    // Unknowns in units of L, as the LM solve's; D and alpha converted accordingly.
    const double D = opt.stepD, alpha = opt.alphaL2;
    std::vector<double> x(size_t(n), 1.0), grad(size_t(n), 0.0);
    int iterations = 0;
    double e = energy(x);
    while (iterations < opt.maxIterations && std::isfinite(e) && std::sqrt(e) > CONVERGED) {
        for (int j = 0; j < n; ++j) {
            std::vector<double> xd = x;
            xd[size_t(j)] += D;
            grad[size_t(j)] = (energy(xd) - e) / D; // eqs. 12, 14
        }
        std::vector<double> next = x;
        for (int j = 0; j < n; ++j) next[size_t(j)] -= alpha * grad[size_t(j)];
        if (p.mode == local::Mode::Scale) {
            for (int j = 0; j < n; ++j) next[size_t(j)] = std::max(next[size_t(j)], 1.0 - p.base.r[p.vars[size_t(j)]] / p.L);
        }
        const double en = energy(next);
        ++iterations;
        if (!std::isfinite(en)) break; // left the tube's domain: keep the last point
        x = next;
        e = en;
    }
    return local::judge(p, x.data(), iterations);
}

/// The baseline on the public functions' input (same checks); refusals are in Outcome::refused.
inline Result<local::Outcome> localShadowEdit(const Light& light, const dvec3& S, const dvec3& Ct, const dvec3& CtNew,
                                              const Selection& selected, local::Mode mode, const Options& opt = {}) {
    local::Problem p;
    if (auto s = local::prepare(light, S, Ct, CtNew, selected, mode, p); !s) return s.error();
    return steepestDescent(p, opt);
}

} // namespace paper

/// The LM solve on the public functions' input, refusals in Outcome::refused (for benchmarks and
/// tests: Outcome::occluder reports the samples' residual).
inline Result<local::Outcome> localShadowSolve(const Light& light, const dvec3& S, const dvec3& Ct, const dvec3& CtNew,
                                               const Selection& selected, local::Mode mode,
                                               const std::vector<dvec3>& occluderSamples = {}) {
    local::Problem p;
    if (auto s = local::prepare(light, S, Ct, CtNew, selected, mode, p, occluderSamples); !s) return s.error();
    return local::solve(p);
}

} // namespace dfb::indirect
