// BendyLight math, the GLSL mirror of server/include/dfb/lightmath/BendyLight.h (paper 000
// sections 3-4). Keep the two in step: tests/gpu/bendy_light_parity_test.cpp runs these functions
// through EGL on random points and compares them with the C++.
// Chain data: BendyBlock, mirrored by dfb::engine::BendyBlock (server/src/engine/UniformBlocks.h).

#define BENDY_MAX_SEGMENTS 8
#define BENDY_MAX_POINTS 17
#ifndef UBO_BENDY
#define UBO_BENDY 2
#endif

layout(std140, binding = UBO_BENDY) uniform BendyBlock {
    vec4 bendyP[BENDY_MAX_POINTS];            // xyz control point (world), w radius
    vec4 bendyC[BENDY_MAX_POINTS];            // rgb colour
    vec4 bendyFrameV[BENDY_MAX_SEGMENTS + 1]; // xyz v_hat at each segment's start, w arc length there
    vec4 bendyAxisU;                          // xyz spotlight axis uL, w tan(theta)
    vec4 bendyAxisV;                          // xyz vL, w number of segments K
    vec4 bendyAxisW;                          // xyz wL, w 1 = exact light direction
    vec4 bendyEnd;                            // xyz P'(K) (extension direction), w R'(K)
} uBendy;

int bendySegments() { return int(uBendy.bendyAxisV.w + 0.5); }

// ---- Bezier segment (eqs. 1, 2) ----
vec3 chainPoint(int k, float t) {
    int K = bendySegments();
    if (k >= K) return uBendy.bendyP[2 * K].xyz + uBendy.bendyEnd.xyz * t;
    float s = 1.0 - t;
    return uBendy.bendyP[2 * k].xyz * (s * s) + uBendy.bendyP[2 * k + 1].xyz * (2.0 * s * t) + uBendy.bendyP[2 * k + 2].xyz * (t * t);
}

vec3 chainDerivative(int k, float t) {
    if (k >= bendySegments()) return uBendy.bendyEnd.xyz;
    return (uBendy.bendyP[2 * k + 1].xyz - uBendy.bendyP[2 * k].xyz) * (2.0 * (1.0 - t)) +
           (uBendy.bendyP[2 * k + 2].xyz - uBendy.bendyP[2 * k + 1].xyz) * (2.0 * t);
}

vec3 chainSecondDerivative(int k) {
    if (k >= bendySegments()) return vec3(0.0);
    return (uBendy.bendyP[2 * k].xyz - uBendy.bendyP[2 * k + 1].xyz * 2.0 + uBendy.bendyP[2 * k + 2].xyz) * 2.0;
}

float chainRadius(int k, float t) {
    int K = bendySegments();
    if (k >= K) return uBendy.bendyP[2 * K].w + uBendy.bendyEnd.w * t;
    float s = 1.0 - t;
    return uBendy.bendyP[2 * k].w * (s * s) + uBendy.bendyP[2 * k + 1].w * (2.0 * s * t) + uBendy.bendyP[2 * k + 2].w * (t * t);
}

float chainRadiusDerivative(int k, float t) {
    if (k >= bendySegments()) return uBendy.bendyEnd.w;
    return (uBendy.bendyP[2 * k + 1].w - uBendy.bendyP[2 * k].w) * (2.0 * (1.0 - t)) +
           (uBendy.bendyP[2 * k + 2].w - uBendy.bendyP[2 * k + 1].w) * (2.0 * t);
}

vec3 chainColor(int k, float t) {
    int K = bendySegments();
    if (k >= K) return uBendy.bendyC[2 * K].rgb;
    float s = 1.0 - t;
    return uBendy.bendyC[2 * k].rgb * (s * s) + uBendy.bendyC[2 * k + 1].rgb * (2.0 * s * t) + uBendy.bendyC[2 * k + 2].rgb * (t * t);
}

// ---- Tube frame ----
vec3 minimalRotation(vec3 a, vec3 b, vec3 x) {
    vec3 s = a + b;
    return x + b * (2.0 * dot(x, a)) - s * (dot(x, s) / (1.0 + dot(a, b)));
}

void tubeFrame(int k, float t, out vec3 uHat, out vec3 vHat, out vec3 wHat) {
    uHat = normalize(chainDerivative(k, t));
    vec3 start = normalize(chainDerivative(k, 0.0));
    int K = bendySegments();
    vHat = normalize(minimalRotation(start, uHat, uBendy.bendyFrameV[k < K ? k : K].xyz));
    wHat = cross(uHat, vHat);
}

vec3 unitTangentDerivative(int k, float t) {
    vec3 d = chainDerivative(k, t);
    float len = length(d);
    vec3 uHat = d / len;
    vec3 dd = chainSecondDerivative(k);
    return (dd - uHat * dot(uHat, dd)) / len;
}

// ---- Arc length (8-point Gauss-Legendre) ----
float segmentArcLength(int k, float t) {
    if (k >= bendySegments()) return length(uBendy.bendyEnd.xyz) * t;
    const float x[4] = float[4](0.1834346424956498, 0.5255324099163290, 0.7966664774136267, 0.9602898564975363);
    const float w[4] = float[4](0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763);
    float sum = 0.0;
    for (int i = 0; i < 4; ++i) {
        sum += w[i] * (length(chainDerivative(k, t * 0.5 * (1.0 + x[i]))) + length(chainDerivative(k, t * 0.5 * (1.0 - x[i]))));
    }
    return sum * t * 0.5;
}

float arcLength(int k, float t) { return uBendy.bendyFrameV[k].w + segmentArcLength(k, t); }

// ---- Cubic solver (paper eq. 10 and section 4) ----
float cbrtSigned(float x) { return sign(x) * pow(abs(x), 1.0 / 3.0); }

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
            roots[n++] = -a0 / a1;
        } else {
            float disc = a1 * a1 - 4.0 * a2 * a0;
            if (disc < 0.0) return 0;
            float q = -0.5 * (a1 + (a1 < 0.0 ? -1.0 : 1.0) * sqrt(disc));
            roots[n++] = q / a2;
            if (q != 0.0) roots[n++] = a0 / q;
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
            roots[n++] = A + B - shift;
        } else {
            float m = sqrt(max(-p / 3.0, 0.0));
            float arg = m > 0.0 ? (3.0 * q) / (2.0 * p * m) : 0.0;
            arg = clamp(arg, -1.0, 1.0);
            float phi = acos(arg) / 3.0;
            const float twoPiOver3 = 2.0943951023931954923;
            for (int i = 0; i < 3; ++i) roots[n++] = 2.0 * m * cos(phi - twoPiOver3 * float(i)) - shift;
        }
    }
    for (int i = 0; i < n; ++i) {
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

// ---- Inverse mapping (eqs. 4-7) ----
struct TubeCoords {
    bool valid;
    bool inside;
    int segment;
    float t;
    float v;
    float w;
};

bool tubeCoordinates(vec3 Q, int k, float t, out TubeCoords c) {
    c.valid = false; c.inside = false; c.segment = 0; c.t = 0.0; c.v = 0.0; c.w = 0.0;
    float R = chainRadius(k, t);
    if (!(R > 0.0)) return false;
    vec3 uHat, vHat, wHat;
    tubeFrame(k, t, uHat, vHat, wHat);
    vec3 d = Q - chainPoint(k, t);
    c.valid = true;
    c.segment = k;
    c.t = t;
    c.v = dot(d, vHat) / R; // eq. 5
    c.w = dot(d, wHat) / R; // eq. 6
    c.inside = c.v * c.v + c.w * c.w <= 1.0;
    return true;
}

TubeCoords inverseMapImpl(vec3 Q, bool culled) {
    TubeCoords best;
    best.valid = false; best.inside = false; best.segment = 0; best.t = 0.0; best.v = 0.0; best.w = 0.0;
    bool found = false, bestInside = false;
    float bestR2 = 0.0, bestT = 0.0;
    int bestK = 0;
    const float slack = 1e-4;
    int K = bendySegments();
    for (int k = 0; k <= K; ++k) {
        float roots[3];
        int n;
        if (k < K) {
            if (culled) {
                // The tube around segment k lies in the sphere around its control points' centroid
                // that holds them all, grown by the largest radius (a quadratic Bezier stays in its
                // control polygon's hull; its radius between its control radii). Skipping the
                // solve outside it only changes points that are inside no tube: unlit anyway.
                vec3 c = (uBendy.bendyP[2 * k].xyz + uBendy.bendyP[2 * k + 1].xyz + uBendy.bendyP[2 * k + 2].xyz) / 3.0;
                float reach = sqrt(max(max(dot(uBendy.bendyP[2 * k].xyz - c, uBendy.bendyP[2 * k].xyz - c),
                                           dot(uBendy.bendyP[2 * k + 1].xyz - c, uBendy.bendyP[2 * k + 1].xyz - c)),
                                       dot(uBendy.bendyP[2 * k + 2].xyz - c, uBendy.bendyP[2 * k + 2].xyz - c))) +
                              1.1 * max(max(uBendy.bendyP[2 * k].w, uBendy.bendyP[2 * k + 1].w), uBendy.bendyP[2 * k + 2].w) + 1e-4;
                if (dot(Q - c, Q - c) > reach * reach) continue;
            }
            vec3 A = uBendy.bendyP[2 * k].xyz - uBendy.bendyP[2 * k + 1].xyz * 2.0 + uBendy.bendyP[2 * k + 2].xyz;
            vec3 B = (uBendy.bendyP[2 * k + 1].xyz - uBendy.bendyP[2 * k].xyz) * 2.0;
            vec3 D = Q - uBendy.bendyP[2 * k].xyz;
            n = solveCubic(2.0 * dot(A, A), 3.0 * dot(A, B), dot(B, B) - 2.0 * dot(A, D), -dot(B, D), roots);
        } else {
            vec3 dir = uBendy.bendyEnd.xyz;
            roots[0] = dot(Q - uBendy.bendyP[2 * K].xyz, dir) / dot(dir, dir);
            roots[1] = 0.0; roots[2] = 0.0;
            n = 1;
        }
        for (int i = 0; i < n; ++i) {
            float t = roots[i];
            float hi = k < K ? 1.0 + slack : 3.4e38;
            if (!(t >= -slack && t <= hi)) continue;
            float R = chainRadius(k, t);
            if (!(R > 0.0)) continue;
            // At a foot v^2 + w^2 = |Q - P|^2 / R^2: rank without frames (see the C++).
            vec3 d = Q - chainPoint(k, t);
            float r2 = dot(d, d) / (R * R);
            bool inside = r2 <= 1.0;
            if (!found || (inside && !bestInside) || (inside == bestInside && r2 < bestR2)) {
                found = true;
                bestInside = inside;
                bestR2 = r2;
                bestK = k;
                bestT = t;
            }
        }
    }
    if (found) tubeCoordinates(Q, bestK, bestT, best);
    return best;
}

TubeCoords inverseMap(vec3 Q) { return inverseMapImpl(Q, false); }

// inverseMap for shading: the same answer for every point inside a tube (and its extension); for
// points inside none it may find no foot (valid = false) instead of the nearest outside one,
// which shading treats alike (unlit). Casters must use inverseMap: their outside vertices matter.
TubeCoords inverseMapForShading(vec3 Q) { return inverseMapImpl(Q, true); }

// Eq. 7 with arc length: Q' = p0 + s uL + s tan(theta) (v vL + w wL).
vec3 deformedPoint(TubeCoords c) {
    float s = arcLength(c.segment, c.t);
    float rho = s * uBendy.bendyAxisU.w;
    return uBendy.bendyP[0].xyz + uBendy.bendyAxisU.xyz * s + (uBendy.bendyAxisV.xyz * c.v + uBendy.bendyAxisW.xyz * c.w) * rho;
}

// Eq. 9 (default) or the exact flow-line tangent; unit, towards the light.
vec3 lightDirection(TubeCoords c, vec3 Q, bool exact) {
    vec3 P = chainPoint(c.segment, c.t);
    vec3 d = chainDerivative(c.segment, c.t);
    float R = chainRadius(c.segment, c.t);
    float dR = chainRadiusDerivative(c.segment, c.t);
    vec3 flow = d + (Q - P) * (dR / R);
    if (exact) {
        vec3 uHat = normalize(d);
        flow -= uHat * dot(Q - P, unitTangentDerivative(c.segment, c.t));
    }
    return -normalize(flow);
}

// Tessellation level of a caster edge for the deformed shadow map (shadow_bendy.tesc and
// bendy_classify.comp): a straight edge of deformed length L where the deformation bends with
// curvature kappa deviates from the true deformed curve by about e = kappa L^2 / 8; n pieces cut
// that to e / n^2, so n = sqrt(e / tol) with tol = 0.25 shadow-map texels at the edge's distance.
// a, b: deformed endpoints (w = 1 if mapped).
float bendyEdgeLevel(vec4 a, vec4 b, float kappa, float texelPerDistance, float maxLevel) {
    if (a.w < 0.5 || b.w < 0.5) return 1.0; // dropped by the fragment stage anyway
    vec3 m = 0.5 * (a.xyz + b.xyz);
    float dist = max(dot(m - uBendy.bendyP[0].xyz, uBendy.bendyAxisU.xyz), 1e-6);
    float L = length(a.xyz - b.xyz);
    float e = kappa * L * L / 8.0 / (texelPerDistance * dist);
    return clamp(ceil(sqrt(e / 0.25)), 1.0, maxLevel);
}
