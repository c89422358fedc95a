// dfb-ltc-fit OUT.h: fits the linearly transformed cosines of the product's GGX lobe (Brdf.h's
// specular term D Vis (N.l) with F = 1, including its height-correlated Smith masking-shadowing)
// and writes them as the C++ header dfb/lightmath/LtcTableData.h (dfb/lightmath/Ltc.h describes
// the layout). Runs at build time; deterministic (stratified samples, no random numbers).
//
// The method is Heitz, Dupuy, Hill and Neubelt, "Real-Time Polygonal-Light Shading with Linearly
// Transformed Cosines", 2016 ("LTC 2016"), its fitting of a BRDF:
// - per (roughness, theta_v) the lobe's magnitude (norm) and mean direction by importance
//   sampling the GGX normals (the LTC's third axis is the lobe's mean direction);
// - M = [X Y Z] [[m11, 0, m13], [0, m22, 0], [0, 0, 1]], X, Y, Z the frame of the mean direction
//   in the plane of V and N, fitted by Nelder-Mead (Nelder and Mead, "A Simplex Method for
//   Function Minimization", 1965) on the cubed difference of the two distributions, each sample
//   weighted by the sum of the two sampling densities (the balance heuristic over samples from
//   both: the error metric of the paper's fitting code);
// - at normal incidence the lobe is round (m22 = m11, m13 = 0); each cell starts from its
//   neighbour: from rough to smooth at normal incidence, then towards grazing views.
// Plus the Schlick weight's share fresnel = integral of f (N.l) (1 - v.h)^5 over the hemisphere
// (the paper's Fresnel term), so that F0 norm + (F90 - F0) fresnel is Brdf.h's Fresnel-weighted
// lobe exactly.

#include <dfb/lightmath/Brdf.h>
#include <dfb/lightmath/Ltc.h>

#include <glm/glm.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

namespace {

using dfb::lightmath::LTC_SIZE;
using dfb::lightmath::PI;
using glm::dmat3;
using glm::dvec3;

// Stratified samples per side for the norm, fresnel and mean direction, and for each error
// evaluation (from each of the two distributions: 2 x 16^2 = 512 samples; LTC 2016's code uses
// 32^2, which gave the same matrices to about 3 digits at the cells compared). The moments'
// integrand 4 Vis (N.l)(v.h) / (n.h) under GGX sampling is smooth, but the last strata of u2
// (grazing half vectors, u2 -> 1) span most of the sphere: with u2 = 1 - (1 - s)^3, s
// stratified, 256^2 samples came within 6e-5 of 1024^2 at the cells tried, where plain
// stratified u2 was 0.6 % off at a grazing view and 1.3 % at roughness 1; 192^2 here, checked by
// tests/unit/lightmath_ltc_test.cpp against a uniform-direction integral (1.7e-4).
constexpr int MOMENT_SAMPLES = 192;
constexpr int ERROR_SAMPLES = 16;
// Smallest m11, m22 the simplex may try: the matrix stays invertible.
constexpr double MIN_SCALE = 1e-5;
// Nelder-Mead stops after this many iterations or when the simplex's errors agree to 1e-5
// (relative).
constexpr int MAX_ITERATIONS = 150;

// The lobe D Vis (N.l) of Brdf.h (F = 1) in the frame where N = z and V = (sin, 0, cos).
struct Lobe {
    double alpha, NdotV;
    dvec3 V;
    double eval(const dvec3& L) const {
        if (L.z <= 0.0)
            return 0.0;
        const dvec3 H = glm::normalize(L + V);
        return dfb::lightmath::distributionGGX(std::max(H.z, 0.0), alpha) *
               dfb::lightmath::visibilitySmithGGX(L.z, NdotV, alpha) * L.z;
    }
    // The density of sample() (GGX normals, D(h)(n.h), reflected: / (4 v.h)).
    double pdf(const dvec3& L) const {
        if (L.z <= 0.0)
            return 0.0;
        const dvec3 H = glm::normalize(L + V);
        return dfb::lightmath::distributionGGX(std::max(H.z, 0.0), alpha) * H.z /
               (4.0 * std::max(glm::dot(V, H), 1e-12));
    }
    // Walter et al. 2007 eqs. 35-36: tan^2 theta_h = alpha^2 u / (1 - u).
    dvec3 sample(double u1, double u2, dvec3* H = nullptr) const {
        const double phi = 2.0 * PI * u1;
        const double t = alpha * std::sqrt(u2 / (1.0 - u2));
        const dvec3 h = glm::normalize(dvec3(t * std::cos(phi), t * std::sin(phi), 1.0));
        if (H)
            *H = h;
        return 2.0 * glm::dot(V, h) * h - V;
    }
};

// The LTC (the paper's definition) with its magnitude.
struct Distribution {
    dmat3 M{1.0}, invM{1.0};
    double detInv = 1.0, amplitude = 1.0;
    void set(const dvec3& X, const dvec3& Y, const dvec3& Z, double m11, double m22, double m13) {
        // glm is column-major: dmat3(c0, c1, c2).
        M = dmat3(X, Y, Z) * dmat3(dvec3(m11, 0, 0), dvec3(0, m22, 0), dvec3(m13, 0, 1));
        invM = glm::inverse(M);
        detInv = std::abs(glm::determinant(invM));
    }
    double eval(const dvec3& L) const {
        const dvec3 o = invM * L;
        const double l = glm::length(o);
        const double cosO = o.z / l;
        return cosO > 0.0 ? amplitude * cosO / PI * detInv / (l * l * l) : 0.0;
    }
    dvec3 sample(double u1, double u2) const {
        const double r = std::sqrt(u1), phi = 2.0 * PI * u2;
        return glm::normalize(
            M * dvec3(r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(1.0 - u1, 0.0))));
    }
};

double fitError(const Distribution& d, const Lobe& b) {
    double err = 0.0;
    auto add = [&](const dvec3& L) {
        const double fb = b.eval(L), fd = d.eval(L);
        const double pb = b.pdf(L), pd = fd / d.amplitude;
        if (pb + pd <= 0.0)
            return;
        const double e = std::abs(fb - fd);
        err += e * e * e / (pb + pd);
    };
    for (int j = 0; j < ERROR_SAMPLES; ++j)
        for (int i = 0; i < ERROR_SAMPLES; ++i) {
            const double u1 = (i + 0.5) / ERROR_SAMPLES, u2 = (j + 0.5) / ERROR_SAMPLES;
            add(d.sample(u1, u2));
            add(b.sample(u1, u2));
        }
    return err / double(ERROR_SAMPLES * ERROR_SAMPLES);
}

// Nelder-Mead on n <= 3 parameters from `x` with initial steps `step`; the standard coefficients
// (reflection 1, expansion 2, contraction 1/2, shrink 1/2). Returns evaluations used.
int nelderMead(int n, std::array<double, 3>& x, const std::array<double, 3>& step,
               const std::function<double(const std::array<double, 3>&)>& f) {
    std::array<std::array<double, 3>, 4> s{};
    std::array<double, 4> v{};
    for (int k = 0; k <= n; ++k) {
        s[size_t(k)] = x;
        if (k > 0)
            s[size_t(k)][size_t(k - 1)] += step[size_t(k - 1)];
        v[size_t(k)] = f(s[size_t(k)]);
    }
    int evals = n + 1;
    auto at = [&](const std::array<double, 3>& c, const std::array<double, 3>& w, double t) {
        std::array<double, 3> r = c;
        for (int i = 0; i < n; ++i)
            r[size_t(i)] = c[size_t(i)] + t * (w[size_t(i)] - c[size_t(i)]);
        return r;
    };
    for (int it = 0; it < MAX_ITERATIONS; ++it) {
        std::array<int, 4> o{0, 1, 2, 3};
        std::sort(o.begin(), o.begin() + n + 1,
                  [&](int a, int b) { return v[size_t(a)] < v[size_t(b)]; });
        const size_t best = size_t(o[0]), worst = size_t(o[size_t(n)]),
                     second = size_t(o[size_t(n - 1)]);
        if (std::abs(v[worst] - v[best]) <= 1e-5 * std::abs(v[best]) + 1e-300)
            break;
        std::array<double, 3> c{};
        for (int k = 0; k <= n; ++k)
            if (size_t(k) != worst)
                for (int i = 0; i < n; ++i)
                    c[size_t(i)] += s[size_t(k)][size_t(i)] / n;
        const auto r = at(c, s[worst], -1.0);
        const double fr = f(r);
        ++evals;
        if (fr < v[best]) {
            const auto e = at(c, s[worst], -2.0);
            const double fe = f(e);
            ++evals;
            if (fe < fr)
                s[worst] = e, v[worst] = fe;
            else
                s[worst] = r, v[worst] = fr;
        } else if (fr < v[second]) {
            s[worst] = r, v[worst] = fr;
        } else {
            const bool outside = fr < v[worst];
            const auto k = at(c, s[worst], outside ? -0.5 : 0.5);
            const double fk = f(k);
            ++evals;
            if (fk < (outside ? fr : v[worst])) {
                s[worst] = k, v[worst] = fk;
            } else {
                for (int q = 0; q <= n; ++q) {
                    if (size_t(q) == best)
                        continue;
                    s[size_t(q)] = at(s[best], s[size_t(q)], 0.5);
                    v[size_t(q)] = f(s[size_t(q)]);
                    ++evals;
                }
            }
        }
    }
    size_t best = 0;
    for (int k = 1; k <= n; ++k)
        if (v[size_t(k)] < v[best])
            best = size_t(k);
    x = s[best];
    return evals;
}

struct Cell {
    double m11 = 1.0, m22 = 1.0, m13 = 0.0;
    std::array<float, 4> inv{};
    double norm = 0.0, fresnel = 0.0;
};

} // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: dfb-ltc-fit OUT.h\n");
        return 2;
    }
    const auto start = std::chrono::steady_clock::now();
    constexpr int N = LTC_SIZE;
    std::vector<Cell> cells(size_t(N) * size_t(N));
    long evaluations = 0;
    for (int i = N - 1; i >= 0; --i) { // roughness, rough to smooth
        for (int j = 0; j < N; ++j) {  // sqrt(1 - N.v), normal incidence to grazing
            const double roughness = double(i) / (N - 1), sv = double(j) / (N - 1);
            Lobe b;
            b.alpha = std::max(roughness * roughness, dfb::lightmath::MIN_ALPHA);
            b.NdotV = std::max(1.0 - sv * sv, dfb::lightmath::MIN_NDOTV);
            b.V = dvec3(std::sqrt(1.0 - b.NdotV * b.NdotV), 0.0, b.NdotV);
            // Magnitude, Schlick share and mean direction (LTC 2016's fitting and Fresnel term).
            double norm = 0.0, fresnel = 0.0;
            dvec3 mean(0.0);
            for (int q = 0; q < MOMENT_SAMPLES; ++q)
                for (int p = 0; p < MOMENT_SAMPLES; ++p) {
                    const double sq = 1.0 - (q + 0.5) / MOMENT_SAMPLES;
                    dvec3 H;
                    const dvec3 L = b.sample((p + 0.5) / MOMENT_SAMPLES, 1.0 - sq * sq * sq, &H);
                    if (L.z <= 0.0)
                        continue;
                    // f (N.l) / pdf = 4 Vis (N.l)(v.h) / (n.h) (D cancels), times du2/ds = 3 (1 -
                    // s)^2.
                    const double VdotH = std::clamp(glm::dot(b.V, H), 0.0, 1.0);
                    const double w = 3.0 * sq * sq * 4.0 *
                                     dfb::lightmath::visibilitySmithGGX(L.z, b.NdotV, b.alpha) *
                                     L.z * VdotH / H.z;
                    norm += w;
                    fresnel += w * std::pow(1.0 - VdotH, 5.0);
                    mean += w * L;
                }
            const double count = double(MOMENT_SAMPLES) * double(MOMENT_SAMPLES);
            norm /= count;
            fresnel /= count;
            mean.y = 0.0;
            mean = glm::length(mean) > 0.0 ? glm::normalize(mean) : dvec3(0, 0, 1);
            Cell& cell = cells[size_t(j) * N + size_t(i)];
            // Seed: the neighbour towards normal incidence, or the rougher lobe at normal
            // incidence.
            const Cell seed = j > 0       ? cells[size_t(j - 1) * N + size_t(i)]
                              : i < N - 1 ? cells[size_t(i + 1)]
                                          : Cell{};
            Distribution d;
            d.amplitude = norm;
            const bool round = j == 0;
            const dvec3 X = round ? dvec3(1, 0, 0) : dvec3(mean.z, 0, -mean.x), Y(0, 1, 0),
                        Z = round ? dvec3(0, 0, 1) : mean;
            auto params = [&](const std::array<double, 3>& x) {
                const double m11 = std::max(x[0], MIN_SCALE);
                if (round)
                    return std::array<double, 3>{m11, m11, 0.0};
                return std::array<double, 3>{m11, std::max(x[1], MIN_SCALE), x[2]};
            };
            auto error = [&](const std::array<double, 3>& x) {
                const auto m = params(x);
                d.set(X, Y, Z, m[0], m[1], m[2]);
                return fitError(d, b);
            };
            std::array<double, 3> x{seed.m11, seed.m22, seed.m13};
            const std::array<double, 3> step{0.1 * x[0], 0.1 * x[1],
                                             0.1 * std::max(std::abs(x[2]), x[0])};
            evaluations += nelderMead(round ? 1 : 3, x, step, error);
            const auto m = params(x);
            d.set(X, Y, Z, m[0], m[1], m[2]);
            cell.m11 = m[0], cell.m22 = m[1], cell.m13 = m[2];
            cell.norm = norm;
            cell.fresnel = fresnel;
            // M^-1 scaled to a middle entry of 1 (the integral ignores the scale): rows
            // [[a, 0, b], [0, 1, 0], [c, 0, d]]; glm's m[col][row].
            const dmat3 inv = d.invM / d.invM[1][1];
            cell.inv = {float(inv[0][0]), float(inv[2][0]), float(inv[0][2]), float(inv[2][2])};
        }
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    std::FILE* out = std::fopen(argv[1], "w");
    if (!out) {
        std::fprintf(stderr, "dfb-ltc-fit: cannot write %s\n", argv[1]);
        return 1;
    }
    std::fprintf(out,
                 "#pragma once\n// Generated by dfb-ltc-fit (server/src/tools/main_ltc_fit.cpp) at "
                 "build time; do not edit.\n"
                 "// The linearly transformed cosines of Brdf.h's GGX lobe, %d x %d (layout: "
                 "dfb/lightmath/Ltc.h,\n"
                 "// LtcTable). Fit: %ld error evaluations of %d samples. Deterministic: the same\n"
                 "// bytes on every run (the fit's time goes to stdout only).\n\n"
                 "#include <dfb/lightmath/Ltc.h>\n\n"
                 "namespace dfb::lightmath {\n\n",
                 N, N, evaluations, 2 * ERROR_SAMPLES * ERROR_SAMPLES);
    std::fprintf(out, "inline constexpr float LTC_MATRIX[%d] = {\n", N * N * 4);
    for (const Cell& c : cells)
        std::fprintf(out, "    %.9g, %.9g, %.9g, %.9g,\n", c.inv[0], c.inv[1], c.inv[2], c.inv[3]);
    std::fprintf(out, "};\n\ninline constexpr float LTC_AMPLITUDE[%d] = {\n", N * N * 2);
    for (const Cell& c : cells)
        std::fprintf(out, "    %.9g, %.9g,\n", float(c.norm), float(c.fresnel));
    std::fprintf(out,
                 "};\n\ninline constexpr LtcTable LTC_TABLE{LTC_MATRIX, LTC_AMPLITUDE};\n\n} // "
                 "namespace dfb::lightmath\n");
    std::fclose(out);
    std::printf("dfb-ltc-fit: %d x %d cells in %.1f s (%ld error evaluations)\n", N, N, seconds,
                evaluations);
    return 0;
}
