#pragma once
// BendyLight math (paper 000 "BendyLights", sections 3-4; DESIGN section 5), written once as
// allocation-free C++ for double and float, with GLSL names so that the GLSL mirror
// (server/shaders/common_bendy.glsl) reads line for line the same. docs/lighting.md derives every
// formula; tests/unit/lightmath_bendy_test.cpp and tests/gpu/bendy_light_parity_test.cpp check it.
//
// Model: a spotlight S (source p0, unit axis uL, frame (uL, vL, wL), cone half-angle theta) and a
// chain of K quadratic Bezier segments with control points p[0..2K] (p[0] = p0): segment k uses
// p[2k], p[2k+1], p[2k+2] with local parameter t in [0,1]; the global parameter is u = k + t.
// Radii r[] and colours c[] are interpolated with the same Bernstein weights (eqs. 1-2). Past the
// last control point the tube continues as a straight cone along the end tangent with the end
// radius slope ("extension", segment index K), so the light reaches the whole scene.

#include <dfb/lightmath/Scalar.h>

#include <glm/glm.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace dfb::lightmath {

/// Most segments a chain may have. Bounds the uniform block (common_bendy.glsl, BENDY_MAX_SEGMENTS).
constexpr int MAX_SEGMENTS = 8;
constexpr int MAX_CONTROL_POINTS = 2 * MAX_SEGMENTS + 1;

/// A BendyLight's chain with the derived quantities prepareChain() computes. Plain data: the GPU
/// receives the same numbers (BendyBlock in server/src/engine/GpuInterface.h).
template <typename T> struct Chain {
    int segments = 1;                        ///< K, 1..MAX_SEGMENTS
    vec3<T> p[MAX_CONTROL_POINTS];           ///< control points, world space; p[0] is the source
    T r[MAX_CONTROL_POINTS];                 ///< tube radii at the control points, > 0
    vec3<T> c[MAX_CONTROL_POINTS];           ///< linear RGB colours at the control points
    vec3<T> axisU, axisV, axisW;             ///< spotlight frame (uL, vL, wL), orthonormal, right-handed
    T tanTheta = T(0.5);                     ///< tan of the spotlight's cone half-angle
    // Derived by prepareChain():
    vec3<T> frameV[MAX_SEGMENTS + 1];        ///< tube frame vector v_hat at the start of each segment (K: the extension)
    T arcStart[MAX_SEGMENTS + 1];            ///< arc length from the source to the start of each segment
    vec3<T> endTangent;                      ///< P'(K), the extension's direction per unit of t
    T endRadiusSlope = T(0);                 ///< R'(K)
};

// ---- Bezier segment (eqs. 1, 2) -------------------------------------------------------------

/// P(t) = p0 (1-t)^2 + 2 p1 (1-t) t + p2 t^2 on segment k; the extension is a straight line.
template <typename T> vec3<T> chainPoint(const Chain<T>& ch, int k, T t) {
    if (k >= ch.segments) return ch.p[2 * ch.segments] + ch.endTangent * t;
    const T s = T(1) - t;
    return ch.p[2 * k] * (s * s) + ch.p[2 * k + 1] * (T(2) * s * t) + ch.p[2 * k + 2] * (t * t);
}

/// P'(t) = 2 (1-t) (p1 - p0) + 2 t (p2 - p1).
template <typename T> vec3<T> chainDerivative(const Chain<T>& ch, int k, T t) {
    if (k >= ch.segments) return ch.endTangent;
    return (ch.p[2 * k + 1] - ch.p[2 * k]) * (T(2) * (T(1) - t)) + (ch.p[2 * k + 2] - ch.p[2 * k + 1]) * (T(2) * t);
}

/// P''(t) = 2 (p0 - 2 p1 + p2), constant per segment.
template <typename T> vec3<T> chainSecondDerivative(const Chain<T>& ch, int k) {
    if (k >= ch.segments) return vec3<T>(T(0));
    return (ch.p[2 * k] - ch.p[2 * k + 1] * T(2) + ch.p[2 * k + 2]) * T(2);
}

/// R(t), eq. 2.
template <typename T> T chainRadius(const Chain<T>& ch, int k, T t) {
    if (k >= ch.segments) return ch.r[2 * ch.segments] + ch.endRadiusSlope * t;
    const T s = T(1) - t;
    return ch.r[2 * k] * (s * s) + ch.r[2 * k + 1] * (T(2) * s * t) + ch.r[2 * k + 2] * (t * t);
}

template <typename T> T chainRadiusDerivative(const Chain<T>& ch, int k, T t) {
    if (k >= ch.segments) return ch.endRadiusSlope;
    return (ch.r[2 * k + 1] - ch.r[2 * k]) * (T(2) * (T(1) - t)) + (ch.r[2 * k + 2] - ch.r[2 * k + 1]) * (T(2) * t);
}

template <typename T> vec3<T> chainColor(const Chain<T>& ch, int k, T t) {
    if (k >= ch.segments) return ch.c[2 * ch.segments];
    const T s = T(1) - t;
    return ch.c[2 * k] * (s * s) + ch.c[2 * k + 1] * (T(2) * s * t) + ch.c[2 * k + 2] * (t * t);
}

// ---- Tube frame -----------------------------------------------------------------------------

/// The rotation of least angle taking unit a to unit b, applied to x (a != -b):
/// R x = x + 2 (x.a) b - (x.(a+b)) / (1 + a.b) (a + b).
template <typename T> vec3<T> minimalRotation(const vec3<T>& a, const vec3<T>& b, const vec3<T>& x) {
    const vec3<T> s = a + b;
    return x + b * (T(2) * glm::dot(x, a)) - s * (glm::dot(x, s) / (T(1) + glm::dot(a, b)));
}

/// Tube frame at (k, t): u_hat = P'/|P'|, and v_hat the segment's start frame carried by the
/// minimal rotation from the start tangent to u_hat. A quadratic Bezier segment is planar and its
/// tangent turns by less than 180 degrees, so this is exactly the rotation-minimising frame
/// (rotation about the plane's normal): continuous, no flips. Joins carry the frame on
/// (prepareChain), and a chain straight along uL keeps (vL, wL).
template <typename T> void tubeFrame(const Chain<T>& ch, int k, T t, vec3<T>& uHat, vec3<T>& vHat, vec3<T>& wHat) {
    uHat = glm::normalize(chainDerivative(ch, k, t));
    const vec3<T> start = glm::normalize(chainDerivative(ch, k, T(0)));
    vHat = glm::normalize(minimalRotation(start, uHat, ch.frameV[k < ch.segments ? k : ch.segments]));
    wHat = glm::cross(uHat, vHat);
}

/// Derivative of the unit tangent with respect to t: (P'' - u_hat (u_hat . P'')) / |P'|.
template <typename T> vec3<T> unitTangentDerivative(const Chain<T>& ch, int k, T t) {
    const vec3<T> d = chainDerivative(ch, k, t);
    const T len = glm::length(d);
    const vec3<T> uHat = d / len;
    const vec3<T> dd = chainSecondDerivative(ch, k);
    return (dd - uHat * glm::dot(uHat, dd)) / len;
}

// ---- Arc length -----------------------------------------------------------------------------

/// Arc length of segment k from 0 to t: integral of |P'| by 8-point Gauss-Legendre quadrature
/// (|P'| is the square root of a quadratic in t, smooth unless the segment has a cusp, which
/// validateChain rejects).
template <typename T> T segmentArcLength(const Chain<T>& ch, int k, T t) {
    if (k >= ch.segments) return glm::length(ch.endTangent) * t;
    const T x[4] = {T(0.1834346424956498), T(0.5255324099163290), T(0.7966664774136267), T(0.9602898564975363)};
    const T w[4] = {T(0.3626837833783620), T(0.3137066458778873), T(0.2223810344533745), T(0.1012285362903763)};
    T sum = T(0);
    for (int i = 0; i < 4; ++i) {
        sum += w[i] * (glm::length(chainDerivative(ch, k, t * T(0.5) * (T(1) + x[i]))) +
                       glm::length(chainDerivative(ch, k, t * T(0.5) * (T(1) - x[i]))));
    }
    return sum * t * T(0.5);
}

template <typename T> T arcLength(const Chain<T>& ch, int k, T t) { return ch.arcStart[k] + segmentArcLength(ch, k, t); }

/// Computes the derived members: segment start frames, arc lengths, the extension.
template <typename T> void prepareChain(Chain<T>& ch) {
    const int K = ch.segments;
    // The chain's first frame is the spotlight's, rotated minimally onto the first tangent.
    vec3<T> tangent = glm::normalize(chainDerivative(ch, 0, T(0)));
    vec3<T> v = glm::normalize(minimalRotation(ch.axisU, tangent, ch.axisV));
    ch.arcStart[0] = T(0);
    for (int k = 0; k < K; ++k) {
        const vec3<T> start = glm::normalize(chainDerivative(ch, k, T(0)));
        // At a join whose tangents differ (a kink), carry the frame across by the minimal rotation.
        v = glm::normalize(minimalRotation(tangent, start, v));
        ch.frameV[k] = v;
        tangent = glm::normalize(chainDerivative(ch, k, T(1)));
        v = glm::normalize(minimalRotation(start, tangent, v));
        ch.arcStart[k + 1] = ch.arcStart[k] + segmentArcLength(ch, k, T(1));
    }
    ch.frameV[K] = v;
    ch.endTangent = chainDerivative(ch, K - 1, T(1));
    ch.endRadiusSlope = chainRadiusDerivative(ch, K - 1, T(1));
}

// ---- Cubic solver (paper eq. 10 and section 4) -----------------------------------------------

/// Real roots of a3 t^3 + a2 t^2 + a1 t + a0 = 0; returns how many (0..3) in `roots`.
/// Cardano's method on the depressed cubic when it has one real root (written to avoid
/// cancellation), the trigonometric form when it has three; a leading coefficient that vanishes
/// relative to the others falls back to the quadratic or linear equation; every root is polished
/// by two Newton steps on the original cubic.
template <typename T> int solveCubic(T a3, T a2, T a1, T a0, T roots[3]) {
    const T scale = glm::max(glm::max(glm::abs(a3), glm::abs(a2)), glm::max(glm::abs(a1), glm::abs(a0)));
    if (!(scale > T(0))) return 0;
    a3 /= scale;
    a2 /= scale;
    a1 /= scale;
    a0 /= scale;
    int n = 0;
    // For the parameter range of interest (|t| <= ~2) a leading term below this is a rounding-level
    // perturbation, and its extra root lies far outside the range.
    const T tiny = sizeof(T) == 4 ? T(1e-5) : T(1e-10);
    if (glm::abs(a3) < tiny) {
        if (glm::abs(a2) < tiny) {
            if (glm::abs(a1) < tiny) return 0;
            roots[n++] = -a0 / a1;
        } else {
            const T disc = a1 * a1 - T(4) * a2 * a0;
            if (disc < T(0)) return 0;
            // Citardauq: q = -(b + sign(b) sqrt(disc)) / 2 avoids cancellation.
            const T q = T(-0.5) * (a1 + (a1 < T(0) ? -T(1) : T(1)) * glm::sqrt(disc));
            roots[n++] = q / a2;
            if (q != T(0)) roots[n++] = a0 / q;
        }
    } else {
        const T b = a2 / a3, c = a1 / a3, d = a0 / a3; // t^3 + b t^2 + c t + d
        const T shift = b / T(3);
        const T p = c - b * b / T(3);
        const T q = T(2) * b * b * b / T(27) - b * c / T(3) + d;
        const T disc = q * q / T(4) + p * p * p / T(27);
        if (disc > T(0)) {
            // One real root (Cardano, eq. 10): the larger cube root first, the other from p.
            const T A = -glm::sign(q) * std::cbrt(glm::abs(q) / T(2) + glm::sqrt(disc));
            const T B = A != T(0) ? -p / (T(3) * A) : T(0);
            roots[n++] = A + B - shift;
        } else {
            // Three real roots: trigonometric form.
            const T m = glm::sqrt(glm::max(-p / T(3), T(0)));
            T arg = m > T(0) ? (T(3) * q) / (T(2) * p * m) : T(0);
            arg = glm::clamp(arg, -T(1), T(1));
            const T phi = glm::acos(arg) / T(3);
            const T twoPiOver3 = T(2.0943951023931954923);
            for (int i = 0; i < 3; ++i) roots[n++] = T(2) * m * glm::cos(phi - twoPiOver3 * T(i)) - shift;
        }
    }
    for (int i = 0; i < n; ++i) {
        T t = roots[i];
        for (int it = 0; it < 2; ++it) {
            const T f = ((a3 * t + a2) * t + a1) * t + a0;
            const T df = (T(3) * a3 * t + T(2) * a2) * t + a1;
            if (df == T(0)) break;
            const T next = t - f / df;
            if (!(glm::abs(next - t) < T(1))) break; // a wild step: keep the closed-form root
            t = next;
        }
        roots[i] = t;
    }
    return n;
}

// ---- Inverse mapping (eqs. 4-7) -----------------------------------------------------------------

/// Where a point sits in the tube: segment k (K = the extension) and local t, so u = k + t;
/// (v, w) the tube coordinates (eqs. 5-6). `valid`: a foot exists with a positive radius (points
/// behind the source have none: unlit, never occluding). `inside`: v^2 + w^2 <= 1.
template <typename T> struct TubeCoords {
    bool valid = false;
    bool inside = false;
    int segment = 0;
    T t = T(0);
    T v = T(0), w = T(0);
};

// Tolerance on t for roots just past a segment's end, where neighbouring segments share the foot.
// The same in float and double, so that both precisions (and the GLSL mirror) consider the same
// candidates.
template <typename T> constexpr T rootSlack() { return T(1e-4); }

/// Evaluates a candidate foot (k, t) for Q; returns false when the radius is not positive.
template <typename T> bool tubeCoordinates(const Chain<T>& ch, const vec3<T>& Q, int k, T t, TubeCoords<T>& out) {
    const T R = chainRadius(ch, k, t);
    if (!(R > T(0))) return false;
    vec3<T> uHat, vHat, wHat;
    tubeFrame(ch, k, t, uHat, vHat, wHat);
    const vec3<T> d = Q - chainPoint(ch, k, t);
    out.valid = true;
    out.segment = k;
    out.t = t;
    out.v = glm::dot(d, vHat) / R; // eq. 5
    out.w = glm::dot(d, wHat) / R; // eq. 6
    out.inside = out.v * out.v + out.w * out.w <= T(1);
    return true;
}

/// The inverse of eqs. 5-6: the undeformed world point at tube coordinates (segment k, local t,
/// v, w), on the flow line of constant (v, w): P(t) + R(t) (v v_hat + w w_hat).
template <typename T> vec3<T> tubePoint(const Chain<T>& ch, int k, T t, T v, T w) {
    vec3<T> uHat, vHat, wHat;
    tubeFrame(ch, k, t, uHat, vHat, wHat);
    return chainPoint(ch, k, t) + (vHat * v + wHat * w) * chainRadius(ch, k, t);
}

/// Solves eq. 4, (Q - P(u)) . P'(u) = 0, on every segment and on the extension, and keeps the
/// foot where Q is inside the tube, the most central if several; if Q is inside at none, the most
/// central foot anyway (so that geometry outside the tube maps outside the cone).
/// With P(t) = A t^2 + B t + C (A = p0 - 2 p1 + p2, B = 2 (p1 - p0), C = p0) and D = Q - C,
/// eq. 4 is the cubic 2|A|^2 t^3 + 3 (A.B) t^2 + (|B|^2 - 2 A.D) t - B.D = 0.
template <typename T> TubeCoords<T> inverseMap(const Chain<T>& ch, const vec3<T>& Q) {
    TubeCoords<T> best;
    bool found = false, bestInside = false;
    T bestR2 = T(0), bestT = T(0);
    int bestK = 0;
    const T slack = rootSlack<T>();
    for (int k = 0; k <= ch.segments; ++k) {
        T roots[3];
        int n;
        if (k < ch.segments) {
            const vec3<T> A = ch.p[2 * k] - ch.p[2 * k + 1] * T(2) + ch.p[2 * k + 2];
            const vec3<T> B = (ch.p[2 * k + 1] - ch.p[2 * k]) * T(2);
            const vec3<T> D = Q - ch.p[2 * k];
            n = solveCubic(T(2) * glm::dot(A, A), T(3) * glm::dot(A, B), glm::dot(B, B) - T(2) * glm::dot(A, D),
                           -glm::dot(B, D), roots);
        } else {
            // Extension: P(t) = pEnd + T t, so the foot is t = (Q - pEnd).T / |T|^2, t >= 0.
            const vec3<T> dir = ch.endTangent;
            roots[0] = glm::dot(Q - ch.p[2 * ch.segments], dir) / glm::dot(dir, dir);
            n = 1;
        }
        for (int i = 0; i < n; ++i) {
            const T t = roots[i];
            const T hi = k < ch.segments ? T(1) + slack : T(3.4e38);
            // Roots a hair outside a segment (rounding at a join) are kept as they are: the
            // segment's polynomial extends smoothly, so the foot stays exact.
            if (!(t >= -slack && t <= hi)) continue;
            const T R = chainRadius(ch, k, t);
            if (!(R > T(0))) continue;
            // At a foot Q - P is orthogonal to u_hat, so v^2 + w^2 = |Q - P|^2 / R^2: candidates
            // are ranked without their frames, which only the chosen one needs.
            const vec3<T> d = Q - chainPoint(ch, k, t);
            const T r2 = glm::dot(d, d) / (R * R);
            const bool inside = r2 <= T(1);
            // Inside beats outside; then the most central.
            if (!found || (inside && !bestInside) || (inside == bestInside && r2 < bestR2)) {
                found = true;
                bestInside = inside;
                bestR2 = r2;
                bestK = k;
                bestT = t;
            }
        }
    }
    if (found) tubeCoordinates(ch, Q, bestK, bestT, best);
    return best;
}

/// Eq. 7 with the arc length: Q' = p0 + s uL + rho(s) (v vL + w wL), rho(s) = s tan(theta), the
/// undeformed cone's radius at distance s. A straight chain along uL whose radii match the cone
/// maps every point to itself.
template <typename T> vec3<T> deformedPoint(const Chain<T>& ch, const TubeCoords<T>& c) {
    const T s = arcLength(ch, c.segment, c.t);
    const T rho = s * ch.tanTheta;
    return ch.p[0] + ch.axisU * s + (ch.axisV * c.v + ch.axisW * c.w) * rho;
}

/// The light direction at Q (unit, towards the light).
/// Default, paper eq. 9: Li = -normalize(P'(u) + (Q - P(u)) R'(u) / R(u)).
/// `exact`: the tangent of the flow line through Q (constant v, w) for the rotation-minimising
/// frame, which adds -((Q - P) . u_hat') u_hat inside the parentheses (docs/lighting.md).
template <typename T> vec3<T> lightDirection(const Chain<T>& ch, const TubeCoords<T>& c, const vec3<T>& Q, bool exact) {
    const vec3<T> P = chainPoint(ch, c.segment, c.t);
    const vec3<T> d = chainDerivative(ch, c.segment, c.t);
    const T R = chainRadius(ch, c.segment, c.t);
    const T dR = chainRadiusDerivative(ch, c.segment, c.t);
    vec3<T> flow = d + (Q - P) * (dR / R);
    if (exact) {
        const vec3<T> uHat = glm::normalize(d);
        flow -= uHat * glm::dot(Q - P, unitTangentDerivative(ch, c.segment, c.t));
    }
    return -glm::normalize(flow);
}

// ---- Occlusion by a plane ---------------------------------------------------------------------

/// Whether the chain's light cannot meet the plane n . x = d (n unit) on its way to any point on
/// the plane's positive side (n . x >= d), so that the plane can be left out of the deformed
/// shadow map when every receiver lies on that side (engine::Casters::indicesFor). Conservative: true
/// only when proven. The light reaches a point at tube coordinates (s, v, w) along its flow line,
/// the points (s' < s, v, w): the deformed map's ray from the source to its Q' (eq. 7). With
/// h = n . x - d along a flow line X(t) = P(t) + R(t) (v v_hat + w w_hat), v^2 + w^2 <= rho^2:
///  - a segment whose tube lies at h > eps keeps h > 0 (bounded by the capsule around its chord of
///    radius |2 p1 - p0 - p2| / 4 + its largest radius, grown by rho);
///  - after the first segment that does not, every piece must keep h non-increasing, so that each
///    earlier point of a flow line is at least as high as the receiver: h' = n . P' + R' (v n.v_hat
///    + w n.w_hat) - R (n . u_hat) (v u_hat'.v_hat + w u_hat'.w_hat) (the rotation-minimising
///    frame turns only about the tangent: v_hat' = -(u_hat' . v_hat) u_hat), at most
///    n . P' + rho (|R'| |n_perp| + R |n . u_hat| |u_hat'|), |n_perp| = sqrt(1 - (n . u_hat)^2),
///    |u_hat'| = |P' x P''| / |P'|^2, bounded on 16 pieces of t (P' and R' are linear in t: the
///    extremes of n . P', |R'| and |P' x P''| lie at a piece's ends, of |P'| at its ends or its
///    closest point to 0);
///  - the extension's flow lines are straight (constant frame), h linear along them: with the
///    chain clear so far, positive at its start and non-negative at the receiver means positive in
///    between; after a piece that was not clear it must descend,
///    n . E + rho |R'_E| sqrt(1 - (n . E_hat)^2) <= 0.
/// A kink (a join whose tangents differ) after the first piece that is not clear moves flow lines
/// sideways: not proven.
template <typename T> bool flowLinesMissPlane(const Chain<T>& ch, const vec3<T>& n, T d, T eps) {
    const T rho = T(1.01); // as the footprint's growth; PCF reads a texel or two past the tube's edge
    auto h = [&](const vec3<T>& x) { return glm::dot(n, x) - d; };
    bool touched = false;
    for (int k = 0; k < ch.segments; ++k) {
        const vec3<T> p0 = ch.p[2 * k], p1 = ch.p[2 * k + 1], p2 = ch.p[2 * k + 2];
        const T rMax = std::max(std::max(ch.r[2 * k], ch.r[2 * k + 1]), ch.r[2 * k + 2]);
        const T reach = (T(0.25) * glm::length(p1 * T(2) - p0 - p2) + rMax) * rho;
        if (!touched && std::min(h(p0), h(p2)) - reach > eps) continue;
        if (touched && k > 0) {
            const vec3<T> before = glm::normalize(chainDerivative(ch, k - 1, T(1)));
            if (glm::dot(before, glm::normalize(chainDerivative(ch, k, T(0)))) < T(1) - T(1e-6)) return false;
        }
        touched = true;
        const vec3<T> dd = chainSecondDerivative(ch, k);
        const int PIECES = 16;
        for (int i = 0; i < PIECES; ++i) {
            const T ta = T(i) / T(PIECES), tb = T(i + 1) / T(PIECES);
            const vec3<T> da = chainDerivative(ch, k, ta), db = chainDerivative(ch, k, tb);
            const T descent = std::max(glm::dot(n, da), glm::dot(n, db));
            const T radiusSlope = std::max(std::abs(chainRadiusDerivative(ch, k, ta)), std::abs(chainRadiusDerivative(ch, k, tb)));
            const T bend = std::max(glm::length(glm::cross(da, dd)), glm::length(glm::cross(db, dd)));
            // The least |P'| on the piece: P' runs along the line from da to db.
            const vec3<T> e = db - da;
            const T along = glm::dot(e, e) > T(0) ? saturate(-glm::dot(da, e) / glm::dot(e, e)) : T(0);
            const T slow = glm::length(da + e * along), fast = std::max(glm::length(da), glm::length(db));
            if (!(slow > T(0))) return false;
            // The range of n . u_hat = n . P' / |P'| on the piece, for |n . u_hat| and |n_perp|.
            const T nLo = std::min(glm::dot(n, da), glm::dot(n, db));
            const T cosLo = std::max(T(-1), std::min(nLo / slow, nLo / fast));
            const T cosHi = std::min(T(1), std::max(descent / slow, descent / fast));
            const T cosMax = std::max(std::abs(cosLo), std::abs(cosHi));
            const T cosMin = cosLo <= T(0) && cosHi >= T(0) ? T(0) : std::min(std::abs(cosLo), std::abs(cosHi));
            const T across = std::sqrt(std::max(T(0), T(1) - cosMin * cosMin));
            if (descent + rho * (radiusSlope * across + rMax * cosMax * bend / (slow * slow)) > T(0)) return false;
        }
    }
    if (!touched) return true;
    const vec3<T> E = ch.endTangent;
    const T len = glm::length(E);
    if (!(len > T(0))) return false;
    const T across = std::sqrt(std::max(T(0), T(1) - glm::dot(n, E) * glm::dot(n, E) / (len * len)));
    return glm::dot(n, E) + rho * std::abs(ch.endRadiusSlope) * across <= T(0);
}

} // namespace dfb::lightmath
