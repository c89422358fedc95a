// BendyLight math, the GLSL mirror of server/include/dfb/lightmath/BendyLight.h (paper 000
// sections 3-4). Keep the two in step: tests/gpu/bendy_light_parity_test.cpp runs these functions
// through EGL on random points and compares them with the C++.
// Chain data: BendyBlock, mirrored by dfb::engine::BendyBlock (server/src/engine/GpuInterface.h);
// its binding and array sizes (UBO_BENDY, BENDY_MAX_SEGMENTS, BENDY_MAX_POINTS) come from there.
#include "common_gpu_interface.glsl"

layout(std140, binding = UBO_BENDY) uniform BendyBlock {
    vec4 bendyP[BENDY_MAX_POINTS];            // xyz control point (world), w radius
    vec4 bendyC[BENDY_MAX_POINTS];            // rgb colour
    vec4 bendyFrameV[BENDY_MAX_SEGMENTS + 1]; // xyz v_hat at each segment's start, w arc length there
    vec4 bendyAxisU;                          // xyz spotlight axis uL, w tan(theta)
    vec4 bendyAxisV;                          // xyz vL, w number of segments K
    vec4 bendyAxisW;                          // xyz wL, w 1 = exact light direction
    vec4 bendyEnd;                            // xyz P'(K) (extension direction), w R'(K)
    vec4 bendyConeStart[BENDY_MAX_SEGMENTS]; // per segment: xyz p0, w radius there (toBendyBlock)
    vec4 bendyConeChord[BENDY_MAX_SEGMENTS]; // xyz p2 - p0, w 1 / |p2 - p0|^2
    vec4 bendyConeRadius[BENDY_MAX_SEGMENTS];  // x radius change along the chord, y slope term m, z largest curvature
} uBendy;

// Specialised variants fix the number of segments (the segment loops unroll, the control points
// are read at constant indices) and the light-direction model; see common_uniforms.glsl.
#ifdef BENDY_K
int bendySegments() { return BENDY_K; }
#else
int bendySegments() { return int(uBendy.bendyAxisV.w + 0.5); }
#endif
#ifndef BENDY_EXACT
#define BENDY_EXACT (uBendy.bendyAxisW.w > 0.5)
#endif

// ---- Bezier segment (eqs. 1, 2) ----
// A segment's data, read from the block once: with a per-sample segment index every block read is
// a gather, so shading reads a segment once (bendySegment) and evaluates everything from these.
// The extension past the last control point (k == K, a straight line along the end tangent E
// with the radius growing linearly) is the quadratic with control points p, p + E/2, p + E: the
// same formulas then give exactly the line, its constant derivative and zero curvature.
struct BendySegment {
    vec4 p0, p1, p2; // xyz control points, w radii
    vec3 c0, c1, c2; // colours
    vec4 frame;      // xyz v_hat at the segment's start, w arc length there
};

BendySegment bendySegment(int k) {
    BendySegment g;
    int K = bendySegments();
    if (k >= K) {
        g.p0 = uBendy.bendyP[2 * K];
        g.p1 = g.p0 + 0.5 * uBendy.bendyEnd;
        g.p2 = g.p0 + uBendy.bendyEnd;
        g.c0 = uBendy.bendyC[2 * K].rgb;
        g.c1 = g.c0;
        g.c2 = g.c0;
        g.frame = uBendy.bendyFrameV[K];
    } else {
        g.p0 = uBendy.bendyP[2 * k];
        g.p1 = uBendy.bendyP[2 * k + 1];
        g.p2 = uBendy.bendyP[2 * k + 2];
        g.c0 = uBendy.bendyC[2 * k].rgb;
        g.c1 = uBendy.bendyC[2 * k + 1].rgb;
        g.c2 = uBendy.bendyC[2 * k + 2].rgb;
        g.frame = uBendy.bendyFrameV[k];
    }
    return g;
}

// Point and radius together (xyz, w): the radius is the same Bezier of the control radii.
vec4 segmentPoint(BendySegment g, float t) {
    float s = 1.0 - t;
    return g.p0 * (s * s) + g.p1 * (2.0 * s * t) + g.p2 * (t * t);
}
// Derivative of point and radius (xyz, w).
vec4 segmentDerivative(BendySegment g, float t) { return (g.p1 - g.p0) * (2.0 * (1.0 - t)) + (g.p2 - g.p1) * (2.0 * t); }
vec3 segmentSecondDerivative(BendySegment g) { return (g.p0.xyz - g.p1.xyz * 2.0 + g.p2.xyz) * 2.0; }
vec3 segmentColor(BendySegment g, float t) {
    float s = 1.0 - t;
    return g.c0 * (s * s) + g.c1 * (2.0 * s * t) + g.c2 * (t * t);
}

vec3 chainPoint(int k, float t) { return segmentPoint(bendySegment(k), t).xyz; }
vec3 chainDerivative(int k, float t) { return segmentDerivative(bendySegment(k), t).xyz; }
vec3 chainSecondDerivative(int k) { return segmentSecondDerivative(bendySegment(k)); }
float chainRadius(int k, float t) { return segmentPoint(bendySegment(k), t).w; }
float chainRadiusDerivative(int k, float t) { return segmentDerivative(bendySegment(k), t).w; }
vec3 chainColor(int k, float t) { return segmentColor(bendySegment(k), t); }

// ---- Tube frame ----
vec3 minimalRotation(vec3 a, vec3 b, vec3 x) {
    vec3 s = a + b;
    return x + b * (2.0 * dot(x, a)) - s * (dot(x, s) / (1.0 + dot(a, b)));
}

void segmentFrame(BendySegment g, float t, out vec3 uHat, out vec3 vHat, out vec3 wHat) {
    uHat = normalize(segmentDerivative(g, t).xyz);
    vec3 start = normalize(segmentDerivative(g, 0.0).xyz);
    vHat = normalize(minimalRotation(start, uHat, g.frame.xyz));
    wHat = cross(uHat, vHat);
}
void tubeFrame(int k, float t, out vec3 uHat, out vec3 vHat, out vec3 wHat) { segmentFrame(bendySegment(k), t, uHat, vHat, wHat); }

vec3 segmentUnitTangentDerivative(BendySegment g, float t) {
    vec3 d = segmentDerivative(g, t).xyz;
    float len = length(d);
    vec3 uHat = d / len;
    vec3 dd = segmentSecondDerivative(g);
    return (dd - uHat * dot(uHat, dd)) / len;
}
vec3 unitTangentDerivative(int k, float t) { return segmentUnitTangentDerivative(bendySegment(k), t); }

// ---- Arc length (8-point Gauss-Legendre) ----
float segmentArcLength(BendySegment g, float t) {
    const float x[4] = float[4](0.1834346424956498, 0.5255324099163290, 0.7966664774136267, 0.9602898564975363);
    const float w[4] = float[4](0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763);
    float sum = 0.0;
    for (int i = 0; i < 4; ++i) {
        sum += w[i] * (length(segmentDerivative(g, t * 0.5 * (1.0 + x[i])).xyz) + length(segmentDerivative(g, t * 0.5 * (1.0 - x[i])).xyz));
    }
    return sum * t * 0.5;
}

float arcLength(int k, float t) {
    BendySegment g = bendySegment(k);
    return g.frame.w + segmentArcLength(g, t);
}

// ---- Cubic solver (paper eq. 10 and section 4) ----
float cbrtSigned(float x) { return sign(x) * pow(abs(x), 1.0 / 3.0); }

// Roots land at fixed indices (no roots[n++]): an array index that differs between samples makes
// llvmpipe store and load every lane apart, which cost more than all the arithmetic here.
int solveCubic(float a3, float a2, float a1, float a0, out float roots[3]) {
    roots[0] = 0.0; roots[1] = 0.0; roots[2] = 0.0;
    float scale = max(max(abs(a3), abs(a2)), max(abs(a1), abs(a0)));
    if (!(scale > 0.0)) return 0;
    a3 /= scale; a2 /= scale; a1 /= scale; a0 /= scale;
    int n = 0;
    const float tiny = 1e-5;
    if (abs(a3) < tiny) {
        if (abs(a2) < tiny) {
            if (abs(a1) < tiny) return 0;
            roots[0] = -a0 / a1;
            n = 1;
        } else {
            float disc = a1 * a1 - 4.0 * a2 * a0;
            if (disc < 0.0) return 0;
            float q = -0.5 * (a1 + (a1 < 0.0 ? -1.0 : 1.0) * sqrt(disc));
            roots[0] = q / a2;
            n = 1;
            if (q != 0.0) {
                roots[1] = a0 / q;
                n = 2;
            }
        }
    } else {
        float b = a2 / a3, c = a1 / a3, d = a0 / a3;
        float shift = b / 3.0;
        float p = c - b * b / 3.0;
        float q = 2.0 * b * b * b / 27.0 - b * c / 3.0 + d;
        float disc = q * q / 4.0 + p * p * p / 27.0;
        if (disc > 0.0) {
            float A = -sign(q) * cbrtSigned(abs(q) / 2.0 + sqrt(disc));
            float B = A != 0.0 ? -p / (3.0 * A) : 0.0;
            roots[0] = A + B - shift;
            n = 1;
        } else {
            float m = sqrt(max(-p / 3.0, 0.0));
            float arg = m > 0.0 ? (3.0 * q) / (2.0 * p * m) : 0.0;
            arg = clamp(arg, -1.0, 1.0);
            float phi = acos(arg) / 3.0;
            const float twoPiOver3 = 2.0943951023931954923;
            roots[0] = 2.0 * m * cos(phi) - shift;
            roots[1] = 2.0 * m * cos(phi - twoPiOver3) - shift;
            roots[2] = 2.0 * m * cos(phi - 2.0 * twoPiOver3) - shift;
            n = 3;
        }
    }
    for (int i = 0; i < 3; ++i) {
        if (i >= n) break;
        float t = roots[i];
        for (int it = 0; it < 2; ++it) {
            float f = ((a3 * t + a2) * t + a1) * t + a0;
            float df = (3.0 * a3 * t + 2.0 * a2) * t + a1;
            if (df == 0.0) break;
            float next = t - f / df;
            if (!(abs(next - t) < 1.0)) break;
            t = next;
        }
        roots[i] = t;
    }
    return n;
}

// ---- Footprint ----
// Whether P can lie in the tube around segment k: inside the round cone along the segment's chord
// p0 p2 whose radius grows linearly from p0 to p2 (B(t) - chord(t) = t (1 - t) (2 p1 - p0 - p2),
// and the radius likewise: engine::toBendyBlock derives it and brings its numbers). The distance
// from P to the cone's axis point at h, less the radius there, is convex in h; its least lies at
// h* = along + m |off| (along: P's projection onto the chord, off: P's offset from it), clamped.
bool segmentFootprintContains(int k, vec3 P) {
    vec4 start = uBendy.bendyConeStart[k], chord = uBendy.bendyConeChord[k];
    vec2 cone = uBendy.bendyConeRadius[k].xy;
    vec3 d = P - start.xyz;
    float along = dot(d, chord.xyz) * chord.w;
    vec3 off = d - chord.xyz * along;
    float h = clamp(along + cone.y * sqrt(dot(off, off)), 0.0, 1.0);
    vec3 e = d - chord.xyz * h;
    float r = start.w + cone.x * h;
    return dot(e, e) <= r * r;
}

// ---- Inverse mapping (eqs. 4-7) ----
// The foot's segment (g) and what shading needs at the foot travel with the coordinates, so that
// nothing is read or evaluated twice.
struct TubeCoords {
    bool valid;
    bool inside;
    int segment;
    float t;
    float v;
    float w;
    BendySegment g;
    vec4 foot;       // chain point and radius at t
    vec4 derivative; // their derivatives at t
    vec3 uHat, vHat, wHat;
};

// bendySegment(k) for a k that differs between samples: with the number of segments fixed
// (BENDY_K) a choice among constant reads instead of a gather per sample.
BendySegment bendySegmentVarying(int k) {
#ifdef BENDY_K
    BendySegment g = bendySegment(0);
    for (int i = 1; i <= BENDY_K; ++i) {
        if (k == i) g = bendySegment(i);
    }
    return g;
#else
    return bendySegment(k);
#endif
}

// Tube coordinates of Q at the foot t of segment k, whose data `g` the caller has read.
bool segmentTubeCoordinates(vec3 Q, BendySegment g, int k, float t, out TubeCoords c) {
    c.valid = false; c.inside = false; c.segment = k; c.t = t; c.v = 0.0; c.w = 0.0;
    c.g = g;
    c.foot = segmentPoint(c.g, t);
    c.derivative = segmentDerivative(c.g, t);
    float R = c.foot.w;
    if (!(R > 0.0)) return false;
    segmentFrame(c.g, t, c.uHat, c.vHat, c.wHat);
    vec3 d = Q - c.foot.xyz;
    c.valid = true;
    c.v = dot(d, c.vHat) / R; // eq. 5
    c.w = dot(d, c.wHat) / R; // eq. 6
    c.inside = c.v * c.v + c.w * c.w <= 1.0;
    return true;
}
bool tubeCoordinates(vec3 Q, int k, float t, out TubeCoords c) { return segmentTubeCoordinates(Q, bendySegment(k), k, t, c); }

// The best foot so far of the search in inverseMapImpl, with its segment's data (kept by
// selection: reading it again by a per-sample index would be a gather per sample).
struct FootSearch {
    bool found, inside;
    float r2, t;
    int k;
    BendySegment g;
};

// Whether segment g's foot candidate t of Q beats the best so far (inside any tube first, then
// the smaller (v^2 + w^2); the first found on ties), and keeps it if so.
void considerFoot(inout FootSearch s, vec3 Q, BendySegment g, int k, float t, float hi) {
    const float slack = 1e-4;
    if (!(t >= -slack && t <= hi)) return;
    vec4 P = segmentPoint(g, t);
    float R = P.w;
    if (!(R > 0.0)) return;
    // At a foot v^2 + w^2 = |Q - P|^2 / R^2: rank without frames (see the C++).
    vec3 d = Q - P.xyz;
    float r2 = dot(d, d) / (R * R);
    bool inside = r2 <= 1.0;
    if (!s.found || (inside && !s.inside) || (inside == s.inside && r2 < s.r2)) {
        s.found = true;
        s.inside = inside;
        s.r2 = r2;
        s.k = k;
        s.t = t;
        s.g = g;
    }
}

// The feet of Q on segment g (k < K): the roots of (B(t) - Q) . B'(t) = 0 in [0, 1] (eq. 4). With
// `culled`, none where the segment's tube cannot hold Q: the tube lies in the sphere around the
// control points' centroid that holds them all, grown by the largest radius (a quadratic Bezier
// stays in its control polygon's hull; its radius between its control radii). Skipping the solve
// outside it only changes points that are inside no tube: unlit anyway.
void segmentFeet(inout FootSearch s, vec3 Q, BendySegment g, int k, bool culled) {
    if (culled) {
        vec3 c = (g.p0.xyz + g.p1.xyz + g.p2.xyz) / 3.0;
        float reach = sqrt(max(max(dot(g.p0.xyz - c, g.p0.xyz - c), dot(g.p1.xyz - c, g.p1.xyz - c)),
                               dot(g.p2.xyz - c, g.p2.xyz - c))) +
                      1.1 * max(max(g.p0.w, g.p1.w), g.p2.w) + 1e-4;
        if (dot(Q - c, Q - c) > reach * reach) return;
    }
    vec3 A = g.p0.xyz - g.p1.xyz * 2.0 + g.p2.xyz;
    vec3 B = (g.p1.xyz - g.p0.xyz) * 2.0;
    vec3 D = Q - g.p0.xyz;
    float roots[3];
    int n = solveCubic(2.0 * dot(A, A), 3.0 * dot(A, B), dot(B, B) - 2.0 * dot(A, D), -dot(B, D), roots);
    for (int i = 0; i < 3; ++i) {
        if (i < n) considerFoot(s, Q, g, k, roots[i], 1.0 + 1e-4);
    }
}

// The foot of Q on the extension past the last control point (a straight line: one foot).
void extensionFoot(inout FootSearch s, vec3 Q) {
    BendySegment g = bendySegment(bendySegments());
    vec3 dir = uBendy.bendyEnd.xyz;
    considerFoot(s, Q, g, bendySegments(), dot(Q - g.p0.xyz, dir) / dot(dir, dir), 3.4e38);
}

// BENDY_SINGLE (shading only; relight_mask.frag sorts the samples): the sample lies in the
// round cone of at most one segment, so only that segment (found again by the cone test) and the
// extension can hold a tube around it: one cubic instead of K. Written without a loop over the
// two (llvmpipe runs every path of a loop body: both the cubic and the extension's projection
// each time round).
TubeCoords inverseMapImpl(vec3 Q, bool culled) {
    FootSearch s;
    s.found = false; s.inside = false; s.r2 = 0.0; s.t = 0.0; s.k = 0;
    s.g = bendySegment(0);
    int K = bendySegments();
#ifdef BENDY_SINGLE
    int only = K; // none: the extension alone
    for (int k = 0; k < K; ++k) {
        if (segmentFootprintContains(k, Q)) only = k;
    }
    if (only < K) segmentFeet(s, Q, bendySegmentVarying(only), only, culled);
#else
    for (int k = 0; k < K; ++k) segmentFeet(s, Q, bendySegment(k), k, culled);
#endif
    extensionFoot(s, Q);
    TubeCoords best;
    if (!segmentTubeCoordinates(Q, s.g, s.k, s.t, best) || !s.found) best.valid = false;
    return best;
}

TubeCoords inverseMap(vec3 Q) { return inverseMapImpl(Q, false); }

// inverseMap for shading: the same answer for every point inside a tube (and its extension); for
// points inside none it may find no foot (valid = false) instead of the nearest outside one,
// which shading treats alike (unlit). Casters must use inverseMap: their outside vertices matter.
TubeCoords inverseMapForShading(vec3 Q) { return inverseMapImpl(Q, true); }

// Arc length from the source to the foot.
float tubeArcLength(TubeCoords c) { return c.g.frame.w + segmentArcLength(c.g, c.t); }

// Eq. 7 with arc length: Q' = p0 + s uL + s tan(theta) (v vL + w wL).
vec3 deformedPointAt(TubeCoords c, float s) {
    float rho = s * uBendy.bendyAxisU.w;
    return uBendy.bendyP[0].xyz + uBendy.bendyAxisU.xyz * s + (uBendy.bendyAxisV.xyz * c.v + uBendy.bendyAxisW.xyz * c.w) * rho;
}
vec3 deformedPoint(TubeCoords c) { return deformedPointAt(c, tubeArcLength(c)); }

// Eq. 9 (default) or the exact flow-line tangent; unit, towards the light.
vec3 lightDirection(TubeCoords c, vec3 Q, bool exact) {
    vec3 flow = c.derivative.xyz + (Q - c.foot.xyz) * (c.derivative.w / c.foot.w);
    if (exact) flow -= c.uHat * dot(Q - c.foot.xyz, segmentUnitTangentDerivative(c.g, c.t));
    return -normalize(flow);
}

// Tessellation level of a caster edge for the deformed shadow map (shadow_bendy.tesc and
// bendy_classify.comp): a straight edge of deformed length L where the deformation bends with
// curvature kappa deviates from the true deformed curve by about e = kappa L^2 / 8; n pieces cut
// that to e / n^2, so n = sqrt(e / tol) with tol = 0.25 shadow-map texels at the edge's distance.
// a, b: deformed endpoints (w = 1 if mapped); ka, kb: bendy_deform.comp's second texel of each
// (x kappa_eff at the vertex, y its segment, z its lateral growth rho / R). The endpoints' own
// curvature misses a bend that lies between them (a long ground edge whose ends fall on the
// straight first segment and past the chain's end crosses the whole bend: planar under a bent
// light, it self-shadowed 3,500 of 26,000 pixels of engine_shadow_bias_test's bunny plane), so
// kappa is also the largest curvature of every segment the edge's feet span, grown as the
// endpoints' offsets grow.
float bendyEdgeKappa(vec4 ka, vec4 kb) {
    float kappa = max(ka.x, kb.x);
    int first = int(min(ka.y, kb.y) + 0.5), last = int(max(ka.y, kb.y) + 0.5);
    float grow = max(1.0, max(ka.z, kb.z));
    for (int k = first; k <= last && k < bendySegments(); ++k) kappa = max(kappa, uBendy.bendyConeRadius[k].z * grow);
    return kappa;
}
float bendyEdgeLevel(vec4 a, vec4 b, vec4 ka, vec4 kb, float texelPerDistance, float maxLevel) {
    if (a.w < 0.5 || b.w < 0.5) return 1.0; // dropped by the fragment stage anyway
    float kappa = bendyEdgeKappa(ka, kb);
    vec3 m = 0.5 * (a.xyz + b.xyz);
    float dist = max(dot(m - uBendy.bendyP[0].xyz, uBendy.bendyAxisU.xyz), 1e-6);
    float L = length(a.xyz - b.xyz);
    float e = kappa * L * L / 8.0 / (texelPerDistance * dist);
    return clamp(ceil(sqrt(e / 0.25)), 1.0, maxLevel);
}
