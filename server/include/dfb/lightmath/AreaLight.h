#pragma once
// Area lights (docs/lighting.md, "Area lights"): a one-sided planar rectangle or disk with an RGB
// pattern, shaded by one-shot approximate local shading (Wang, Lin, Li and Guo, "One-Shot
// Approximate Local Shading", 2008; "paper 001" below), written once as allocation-free C++ for
// float and double with GLSL names; server/shaders/relight_area.frag mirrors representativePoint,
// phongExponent and the pattern table's box integral (tests/gpu/area_light_test.cpp checks the two
// agree). Also the references the shading is measured against (dense stratified sampling of the
// emitter with the same BRDF) and the fit of the radius factors alpha and beta (paper 001
// section 3).
//
// Conventions: the emitter's normal n points to the side it lights; a shading point p is in
// front when (p - centre).n > 0. The pattern P(u, v) is a linear RGB multiplier over the
// emitter's unit square, u along `right`, v along `up` (v = 1 at the up edge: the image's top row),
// zero outside the emitter (outside a disk's circle too). An emitter of radiance Le shades p with
//   I(p) = integral over S of f(p, t) (N.l) (-l.n) Le P(t) / |p t|^2 dA,  l = (t - p) / |t - p|
// (paper 001 eqs. 1 and 7, with the BRDF f instead of Phong's Kd/Ks).

#include <dfb/lightmath/Brdf.h>
#include <dfb/lightmath/Falloff.h>
#include <dfb/lightmath/Scalar.h>

#include <glm/glm.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace dfb::lightmath {

/// An area light's emitter in world space.
template <typename T> struct AreaFrame {
    vec3<T> centre, normal, right, up; ///< unit normal (emitting side), unit in-plane axes
    T width = T(1), height = T(1);     ///< along right and up; a disk: width = height = diameter
    bool disk = false;
};

/// The emitter's frame for a light at `centre` facing `direction`, turned by `rollDeg` about its
/// normal: right and up from the product's one light frame (spotFrame: right = normalize(n x up),
/// up' = right x n with up = +Y, or +X near vertical), both turned by the roll. A disk's diameter
/// is size.x.
template <typename T>
AreaFrame<T> areaFrame(const vec3<T>& centre, const vec3<T>& direction, T rollDeg, vec2<T> size, bool disk) {
    const SpotFrame<T> s = spotFrame(direction);
    const T a = rollDeg * T(3.14159265358979323846) / T(180);
    const T c = std::cos(a), sn = std::sin(a);
    AreaFrame<T> f;
    f.centre = centre;
    f.normal = s.axis;
    f.right = s.right * c + s.up * sn;
    f.up = s.up * c - s.right * sn;
    f.width = size.x;
    f.height = disk ? size.x : size.y;
    f.disk = disk;
    return f;
}

/// The point of the emitter's plane maximising cos(pt, n) cos^m(pt, A) / |pt|^2 for a shading
/// point p in front of it and a lobe axis A (unit; paper 001 appendix A for the diffuse lobe,
/// A = N, m = 1, eq. 9; appendix B for a Phong lobe around the reflected view vector, A = N_r,
/// m = n, eq. 10). In the plane through p, n and A: eta is the angle between A and the emitter's
/// plane (positive when A points towards it), the maximum lies along A's projection onto the
/// plane at x_p t = h / tan(phi) from p's foot x_p, phi = theta + eta,
///   theta = (acos((m - 3) / (m + 3) cos eta) - eta) / 2
/// (m = 1: eq. 12, acos(-cos(eta) / 2)). A along n or pointing straight at the plane: the foot;
/// A pointing away (phi -> 0): the distance is capped at `reach` (the paper pads the pattern with
/// zeros, so a point far outside gathers only what its box reaches).
template <typename T>
vec3<T> representativePoint(const AreaFrame<T>& f, const vec3<T>& p, const vec3<T>& A, T m, T reach) {
    const T h = glm::dot(p - f.centre, f.normal);
    const vec3<T> foot = p - f.normal * h;
    const T an = glm::dot(A, f.normal);
    const vec3<T> along = A - f.normal * an;
    const T cosEta = glm::length(along);
    if (cosEta < T(1e-6)) return foot;
    const T eta = std::atan2(-an, cosEta);
    const T theta = T(0.5) * (std::acos(std::clamp((m - T(3)) / (m + T(3)) * cosEta, T(-1), T(1))) - eta);
    const T phi = theta + eta;
    const T s = std::sin(phi), c = std::cos(phi);
    const T dist = s > T(0) ? std::min(h * c / s, reach) : reach;
    return foot + along * (std::max(dist, T(0)) / cosEta);
}

/// The point of the emitter nearest to the plane point t (a rectangle: u, v clamped to [0, 1]; a
/// disk: onto its circle). Differs from paper 001: its footnote 3 leaves t1 and t2 unclamped
/// (the pattern is padded with zeros), but Theorem 1 needs t0 in A(p, S), which lies in S; off
/// the emitter the lobe's maximum is far from where the light comes from, and a fixed alpha
/// cannot say how far: a floor point beside a ceiling panel, 5 panel sizes below it, got 0 for
/// alpha |p t1| short of the panel (tests/unit/lightmath_area_test.cpp measures both).
template <typename T> vec3<T> clampToEmitter(const AreaFrame<T>& f, const vec3<T>& t) {
    const vec3<T> d = t - f.centre;
    T x = glm::dot(d, f.right), y = glm::dot(d, f.up);
    if (f.disk) {
        const T r = std::sqrt(x * x + y * y), R = T(0.5) * f.width;
        if (r > R) x *= R / r, y *= R / r;
    } else {
        x = std::clamp(x, T(-0.5) * f.width, T(0.5) * f.width);
        y = std::clamp(y, T(-0.5) * f.height, T(0.5) * f.height);
    }
    return f.centre + f.right * x + f.up * y;
}

/// The Phong exponent (around the reflected view vector) standing in for the GGX lobe of
/// roughness r in one-shot's specular radius beta |p t2| / n (paper 001 section 3.2). GGX with
/// alpha = r^2 and Blinn-Phong D of exponent n_h = 2 / alpha^2 - 2 agree near the peak (Walter et
/// al., "Microfacet Models for Refraction through Rough Surfaces", 2007, section 5.2), and a
/// half-vector lobe of exponent n_h is about a reflection lobe of exponent n_h / 4 (the half angle
/// is half the reflection angle); clamped to [1, 1e4]: rough surfaces keep at least the diffuse
/// lobe's width. docs/lighting.md gives the mapping's error.
template <typename T> T phongExponent(T roughness) {
    const T alpha = std::max(roughness * roughness, T(MIN_ALPHA));
    return std::clamp((T(2) / (alpha * alpha) - T(2)) / T(4), T(1), T(1e4));
}

/// The pattern's prefiltered table: a summed-area table (Crow, "Summed-Area Tables for Texture
/// Mapping", 1984) of P over the emitter's unit square, at the corners of a w x h texel grid:
/// sat[j (w + 1) + i] = integral of P over [0, i/w] x [0, j/h] (row j = 0 at the emitter's down
/// edge). Bilinear interpolation of the corners is the exact integral of the piecewise-constant
/// texels over any box, at any size and aspect, in four reads: one-shot's box of radius alpha |pt|
/// clipped to the emitter (a mip chain gives only power-of-two squares and needs zero padding
/// around the emitter for boxes that leave it; paper 001 section 4's table is 4 MB).
struct PatternTable {
    int w = 1, h = 1;
    std::vector<glm::dvec3> sat; ///< (w + 1) (h + 1) corners
    glm::dvec3 mean{1.0};        ///< integral over the unit square (the pattern's mean)
};

/// The table of an RGB image (rgb: w x h x 3 floats, row 0 = the image's top, the emitter's up
/// edge), or of a uniform white emitter when rgb is empty; a disk's texels are weighted by the
/// fraction of each inside the inscribed circle (4 x 4 subsamples).
inline PatternTable buildPatternTable(const float* rgb, int w, int h, bool disk) {
    PatternTable t;
    if (!rgb) {
        // Uniform: a rectangle is exact at any size with one texel; a disk needs its circle drawn.
        w = h = disk ? 256 : 1;
    }
    t.w = w;
    t.h = h;
    t.sat.assign(size_t(w + 1) * size_t(h + 1), glm::dvec3(0.0));
    const double cell = 1.0 / (double(w) * double(h));
    for (int j = 0; j < h; ++j) {
        glm::dvec3 row(0.0);
        for (int i = 0; i < w; ++i) {
            glm::dvec3 v(1.0);
            if (rgb) {
                const size_t k = (size_t(h - 1 - j) * size_t(w) + size_t(i)) * 3; // image rows top first
                v = glm::dvec3(rgb[k], rgb[k + 1], rgb[k + 2]);
            }
            if (disk) {
                int inside = 0;
                for (int sy = 0; sy < 4; ++sy)
                    for (int sx = 0; sx < 4; ++sx) {
                        const double x = (i + (sx + 0.5) / 4.0) / w - 0.5, y = (j + (sy + 0.5) / 4.0) / h - 0.5;
                        inside += x * x + y * y <= 0.25;
                    }
                v *= inside / 16.0;
            }
            row += v * cell;
            t.sat[size_t(j + 1) * size_t(w + 1) + size_t(i + 1)] = t.sat[size_t(j) * size_t(w + 1) + size_t(i + 1)] + row;
        }
    }
    t.mean = t.sat.back();
    return t;
}

/// The table's S(u, v) (the integral over [0, u] x [0, v]) at (u, v) in [0, 1]^2, bilinear in the
/// corners.
inline glm::dvec3 satAt(const PatternTable& t, double u, double v) {
    const double x = std::clamp(u, 0.0, 1.0) * t.w, y = std::clamp(v, 0.0, 1.0) * t.h;
    const int i = std::min(int(x), t.w - 1), j = std::min(int(y), t.h - 1);
    const double fx = x - i, fy = y - j;
    auto at = [&](int a, int b) { return t.sat[size_t(b) * size_t(t.w + 1) + size_t(a)]; };
    return glm::mix(glm::mix(at(i, j), at(i + 1, j), fx), glm::mix(at(i, j + 1), at(i + 1, j + 1), fx), fy);
}

/// The emitter coordinates (u, v) of a point of its plane.
template <typename T> vec2<T> emitterUv(const AreaFrame<T>& f, const vec3<T>& t) {
    const vec3<T> d = t - f.centre;
    return {glm::dot(d, f.right) / f.width + T(0.5), glm::dot(d, f.up) / f.height + T(0.5)};
}

/// The integral of P over the square of half-side r (world units) around the plane point t,
/// clipped to the emitter: world area units (paper 001 eq. 2 with a square, section 2).
template <typename T> vec3<T> boxIntegral(const AreaFrame<T>& f, const PatternTable& tab, const vec3<T>& t, T r) {
    const vec2<T> uv = emitterUv(f, t);
    const double u0 = std::clamp(double(uv.x - r / f.width), 0.0, 1.0), u1 = std::clamp(double(uv.x + r / f.width), 0.0, 1.0);
    const double v0 = std::clamp(double(uv.y - r / f.height), 0.0, 1.0), v1 = std::clamp(double(uv.y + r / f.height), 0.0, 1.0);
    if (u1 <= u0 || v1 <= v0) return vec3<T>(T(0));
    const glm::dvec3 s = satAt(tab, u1, v1) - satAt(tab, u0, v1) - satAt(tab, u1, v0) + satAt(tab, u0, v0);
    return vec3<T>(glm::max(s, glm::dvec3(0.0)) * (double(f.width) * double(f.height)));
}

/// How far a representative point may lie from its foot: far beyond any box that still reaches
/// the emitter from a shading point (1e4 emitter sizes).
template <typename T> T areaReach(const AreaFrame<T>& f) { return T(1e4) * std::max(f.width, f.height); }

/// Where one-shot differs from paper 001, each measured against the stratified reference
/// (tests/unit/lightmath_area_test.cpp; docs/lighting.md, "Area lights"). The product uses the
/// defaults; `paper()` is the paper's own choice, kept for the measurement.
struct OneShotModel {
    /// Representative points clamped to the emitter (clampToEmitter) instead of footnote 3's
    /// zero padding around an unclamped maximum.
    bool clamp = true;
    /// The box radius r = alpha d Re / sqrt(Re^2 + d^2) (Re the emitter's diagonal) instead of
    /// section 3's r = alpha d: the same near the emitter, and far away a box that stops growing
    /// once it covers the emitter from any point of it. A uniform disk seen from above its centre
    /// needs r = h R / sqrt(R^2 + h^2) exactly, so one constant alpha fits distances that differ
    /// tenfold only with a radius of this shape (the paper's alpha ranges from 1 near to 0.1 at 5
    /// diameters; its 0.30 is their mean).
    bool saturate = true;
    static constexpr OneShotModel paper() { return {false, false}; }
};

/// The length one-shot's box radius is proportional to, for a representative point at distance d
/// (OneShotModel::saturate).
template <typename T> T radiusLength(const AreaFrame<T>& f, T d, OneShotModel model = {}) {
    if (!model.saturate) return d;
    const T re2 = f.width * f.width + f.height * f.height;
    return d * std::sqrt(re2 / (re2 + d * d));
}

/// One-shot's two lobes (paper 001 section 3) for a base-layer material (Brdf.h
/// evaluateBaseLobes), per unit emitter radiance: the diffuse lobe as a point light at t1
/// (clampToEmitter of the lobe's maximum)
/// (diffuse axis N, m = 1) of intensity box(t1, alpha |p t1|), the specular lobe at t2 (axis: the
/// view vector reflected about N, m = phongExponent) of intensity box(t2, beta |p t2| / m), each
/// f (N.l) (-l.n) I / d^2.
template <typename T> struct OneShotPoints {
    vec3<T> t1, t2;
    T r1, r2;
};
template <typename T>
OneShotPoints<T> oneShotPoints(const AreaFrame<T>& f, const vec3<T>& p, const vec3<T>& N, const vec3<T>& V, T roughness,
                               T alpha, T beta, OneShotModel model = {}) {
    OneShotPoints<T> o;
    const T m = phongExponent(roughness);
    const vec3<T> Nr = glm::reflect(-V, N);
    o.t1 = representativePoint(f, p, N, T(1), areaReach(f));
    o.t2 = representativePoint(f, p, Nr, m, areaReach(f));
    if (model.clamp) o.t1 = clampToEmitter(f, o.t1), o.t2 = clampToEmitter(f, o.t2);
    o.r1 = alpha * radiusLength(f, glm::length(o.t1 - p), model);
    o.r2 = beta * radiusLength(f, glm::length(o.t2 - p), model) / m;
    return o;
}

/// A point light's factor (N.l) (-l.n) / d^2 from emitter point t, 0 behind the emitter.
template <typename T> T pointFactor(const AreaFrame<T>& f, const vec3<T>& p, const vec3<T>& N, const vec3<T>& t, vec3<T>* lOut) {
    const vec3<T> d = t - p;
    const T d2 = std::max(glm::dot(d, d), T(1e-12));
    const vec3<T> l = d / std::sqrt(d2);
    if (lOut) *lOut = l;
    return std::max(glm::dot(N, l), T(0)) * std::max(-glm::dot(l, f.normal), T(0)) / d2;
}

template <typename T>
vec3<T> oneShotShading(const AreaFrame<T>& f, const PatternTable& tab, const vec3<T>& p, const vec3<T>& N, const vec3<T>& V,
                       const vec3<T>& albedo, T metallic, T roughness, T specular, T alpha, T beta, OneShotModel model = {}) {
    if (glm::dot(p - f.centre, f.normal) <= T(0)) return vec3<T>(T(0)); // one-sided
    const OneShotPoints<T> o = oneShotPoints(f, p, N, V, roughness, alpha, beta, model);
    vec3<T> l1, l2;
    const T k1 = pointFactor(f, p, N, o.t1, &l1), k2 = pointFactor(f, p, N, o.t2, &l2);
    vec3<T> out(T(0));
    if (k1 > T(0)) out += evaluateBaseLobes(N, l1, V, albedo, metallic, roughness, specular).diffuse * k1 * boxIntegral(f, tab, o.t1, o.r1);
    if (k2 > T(0)) out += evaluateBaseLobes(N, l2, V, albedo, metallic, roughness, specular).specular * k2 * boxIntegral(f, tab, o.t2, o.r2);
    return out;
}

/// The same light by dense stratified sampling (the reference one-shot is measured against):
/// g x g cells over the emitter, each contributing the exact integral of P over the cell (the
/// table) at its centre with the full BRDF.
template <typename T>
vec3<T> referenceShading(const AreaFrame<T>& f, const PatternTable& tab, const vec3<T>& p, const vec3<T>& N, const vec3<T>& V,
                         const vec3<T>& albedo, T metallic, T roughness, T specular, int g) {
    if (glm::dot(p - f.centre, f.normal) <= T(0)) return vec3<T>(T(0));
    vec3<T> out(T(0));
    const T area = f.width * f.height;
    for (int j = 0; j < g; ++j)
        for (int i = 0; i < g; ++i) {
            const double u0 = double(i) / g, u1 = double(i + 1) / g, v0 = double(j) / g, v1 = double(j + 1) / g;
            const glm::dvec3 s = satAt(tab, u1, v1) - satAt(tab, u0, v1) - satAt(tab, u1, v0) + satAt(tab, u0, v0);
            if (s.x <= 0.0 && s.y <= 0.0 && s.z <= 0.0) continue;
            const vec3<T> t = f.centre + f.right * (T((u0 + u1) * 0.5 - 0.5) * f.width) + f.up * (T((v0 + v1) * 0.5 - 0.5) * f.height);
            vec3<T> l;
            const T k = pointFactor(f, p, N, t, &l);
            if (k <= T(0)) continue;
            const BaseLobes<T> b = evaluateBaseLobes(N, l, V, albedo, metallic, roughness, specular);
            out += (b.diffuse + b.specular) * (k * area) * vec3<T>(s);
        }
    return out;
}

/// Paper 001 section 3's fit of one radius factor for one lobe: at sample points p at distances
/// 0.25 .. 5 emitter sizes, above the centre and off it, with the lobe axis A turned from pointing
/// at the emitter to parallel to it (every 15 degrees) and round the normal (4 azimuths), the
/// exact lobe integral by stratified sampling (g x g), and the radius r_i at which the point light
/// at the lobe's representative point equals it (eq. 5, by bisection on the box's radius); the
/// factor is the mean of r_i m / |p t| (m = 1: alpha; m = the Phong exponent: beta). Luminance
/// (the pattern's channel mean) decides; samples whose exact value a full-emitter box cannot
/// reach are skipped. `samples` receives how many were used.
inline double fitRadiusFactor(const AreaFrame<double>& f, const PatternTable& tab, double m, int g = 48, int* samples = nullptr,
                              OneShotModel model = {}) {
    using V3 = glm::dvec3;
    const double size = std::max(f.width, f.height);
    double sum = 0.0;
    int n = 0;
    auto lum = [](const V3& c) { return (c.x + c.y + c.z) / 3.0; };
    for (double hd : {0.25, 0.5, 1.0, 2.0, 3.0, 5.0})
        for (double off : {0.0, 0.25, 0.45})
            for (int az = 0; az < 4; ++az)
                for (int e = 6; e >= 0; --e) {
                    const double phiAz = az * 1.5707963267948966;
                    const V3 side = f.right * std::cos(phiAz) + f.up * std::sin(phiAz);
                    const V3 p = f.centre + f.normal * (hd * size) + side * (off * size);
                    const double eta = e * 15.0 * 3.14159265358979 / 180.0; // the axis' angle below the plane's parallel
                    const V3 A = glm::normalize(side * std::cos(eta) - f.normal * std::sin(eta));
                    V3 t = representativePoint(f, p, A, m, areaReach(f));
                    if (model.clamp) t = clampToEmitter(f, t);
                    // The lobe cos^m(pt, A) (-l.n) / d^2 against the pattern (paper 001 eq. 8).
                    auto rho = [&](const V3& q) {
                        const V3 d = q - p;
                        const double d2 = glm::dot(d, d);
                        const V3 l = d / std::sqrt(d2);
                        const double c = glm::dot(l, A);
                        return c > 0.0 ? std::pow(c, m) * std::max(-glm::dot(l, f.normal), 0.0) / d2 : 0.0;
                    };
                    double exact = 0.0;
                    for (int j = 0; j < g; ++j)
                        for (int i = 0; i < g; ++i) {
                            const double u0 = double(i) / g, u1 = double(i + 1) / g, v0 = double(j) / g, v1 = double(j + 1) / g;
                            const V3 s = satAt(tab, u1, v1) - satAt(tab, u0, v1) - satAt(tab, u1, v0) + satAt(tab, u0, v0);
                            const V3 q = f.centre + f.right * (((u0 + u1) * 0.5 - 0.5) * f.width) + f.up * (((v0 + v1) * 0.5 - 0.5) * f.height);
                            exact += rho(q) * lum(s) * f.width * f.height;
                        }
                    const double at = rho(t);
                    if (!(at > 0.0) || !(exact > 0.0)) continue;
                    const double target = exact / at; // the intensity the point light needs (eq. 4)
                    const double dist = glm::length(t - p);
                    double lo = 0.0, hi = 4.0 * (size + glm::length(t - f.centre));
                    if (lum(boxIntegral(f, tab, t, hi)) < target) continue; // not reachable (eq. 4 fails)
                    for (int it = 0; it < 40; ++it) {
                        const double mid = 0.5 * (lo + hi);
                        (lum(boxIntegral(f, tab, t, mid)) < target ? lo : hi) = mid;
                    }
                    sum += 0.5 * (lo + hi) * m / radiusLength(f, dist, model);
                    ++n;
                }
    if (samples) *samples = n;
    return n ? sum / n : 0.0;
}

/// The Phong exponents beta is fitted at (its mean over them): the lobes of roughness 0.25 .. 0.7.
constexpr double BETA_FIT_EXPONENTS[] = {3.0, 10.0, 30.0};

} // namespace dfb::lightmath
