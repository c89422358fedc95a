// Area lights' light math (server/include/dfb/lightmath/AreaLight.h): one-shot's representative
// points against a brute-force maximum of the lobe over the emitter's plane (Wang et al. 2008,
// appendices A and B), the pattern table's box integrals against closed forms, the fit of alpha
// and beta (section 3) for a uniform disk against the paper's values, and one-shot against the
// stratified reference.

#include <dfb/lightmath/AreaLight.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <random>

using namespace dfb::lightmath;
using V3 = glm::dvec3;

namespace {

AreaFrame<double> unitEmitter(bool disk, double w = 1.0, double h = 1.0) {
    return areaFrame<double>({0, 0, 0}, {0, 0, 1}, 0.0, {w, h}, disk);
}

// The lobe cos(pt, n) cos^m(pt, A) / |pt|^2 (paper 001 eq. 8) at plane point t.
double lobe(const AreaFrame<double>& f, const V3& p, const V3& A, double m, const V3& t) {
    const V3 d = t - p;
    const V3 l = glm::normalize(d);
    const double c = glm::dot(l, A);
    return c > 0 ? std::max(-glm::dot(l, f.normal), 0.0) * std::pow(c, m) / glm::dot(d, d) : 0.0;
}

} // namespace

TEST(AreaLightMath, RepresentativePointMaximisesTheLobe) {
    const AreaFrame<double> f = unitEmitter(false);
    // Diffuse lobe with N parallel to the plane: t at h / sqrt(3) from the foot (appendix A).
    const V3 p(0.2, -0.1, 0.9);
    const V3 t = representativePoint(f, p, V3(1, 0, 0), 1.0, 1e4);
    EXPECT_NEAR(t.x - p.x, 0.9 / std::sqrt(3.0), 1e-9);
    EXPECT_NEAR(t.y, p.y, 1e-12);
    EXPECT_NEAR(t.z, 0.0, 1e-12);
    // N pointing straight at the plane: the foot.
    const V3 foot = representativePoint(f, p, V3(0, 0, -1), 1.0, 1e4);
    EXPECT_NEAR(glm::length(foot - V3(p.x, p.y, 0)), 0.0, 1e-12);
    // Random configurations against a grid search over the plane, m = 1 (diffuse) and Phong lobes.
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    int checked = 0;
    for (int trial = 0; trial < 60; ++trial) {
        const V3 q(u(rng), u(rng), 0.3 + 1.5 * (u(rng) + 1.0));
        V3 A = glm::normalize(V3(u(rng), u(rng), -std::abs(u(rng)) - 0.05)); // towards the plane
        for (double m : {1.0, 3.0, 10.0, 40.0}) {
            const V3 t1 = representativePoint(f, q, A, m, 1e4);
            const double at = lobe(f, q, A, m, t1);
            double best = 0.0;
            for (int i = -200; i <= 200; ++i)
                for (int j = -200; j <= 200; ++j) {
                    const V3 g(q.x + i * 0.02, q.y + j * 0.02, 0.0);
                    best = std::max(best, lobe(f, q, A, m, g));
                }
            EXPECT_GE(at, best * (1.0 - 1e-3)) << "trial " << trial << " m " << m;
            ++checked;
        }
    }
    EXPECT_EQ(checked, 240);
}

TEST(AreaLightMath, PatternTableIntegratesBoxesExactly) {
    // Uniform rectangle, 2 x 0.5: any box clipped to the emitter integrates to its clipped area.
    const AreaFrame<double> f = unitEmitter(false, 2.0, 0.5);
    const PatternTable uniform = buildPatternTable(nullptr, 0, 0, false);
    EXPECT_NEAR(boxIntegral(f, uniform, V3(0.1, 0.05, 0), 0.1).x, 0.04, 1e-12);
    EXPECT_NEAR(boxIntegral(f, uniform, V3(0.95, 0, 0), 0.1).x, 0.15 * 0.2, 1e-12); // half outside at x
    EXPECT_NEAR(boxIntegral(f, uniform, V3(0, 0, 0), 10.0).x, 1.0, 1e-12);          // the whole emitter
    EXPECT_EQ(boxIntegral(f, uniform, V3(3, 0, 0), 0.5).x, 0.0);
    // A 4 x 4 checkerboard (white where (i + j) is even): a box on one white cell, one on a black,
    // one over a 2 x 2 block (half white).
    std::vector<float> rgb(4 * 4 * 3);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x)
            for (int c = 0; c < 3; ++c) rgb[size_t((y * 4 + x) * 3 + c)] = (x + y) % 2 == 0 ? 1.f : 0.f;
    const AreaFrame<double> g = unitEmitter(false);
    const PatternTable checker = buildPatternTable(rgb.data(), 4, 4, false);
    EXPECT_NEAR(checker.mean.x, 0.5, 1e-12);
    auto at = [&](double u, double v) { return g.centre + g.right * (u - 0.5) + g.up * (v - 0.5); };
    // Image row 0 (top) is the emitter's up edge: texel (0, 0) white at u in [0, .25], v in [.75, 1].
    EXPECT_NEAR(boxIntegral(g, checker, at(0.125, 0.875), 0.125).x, 0.0625, 1e-12);
    EXPECT_NEAR(boxIntegral(g, checker, at(0.375, 0.875), 0.125).x, 0.0, 1e-12);
    EXPECT_NEAR(boxIntegral(g, checker, at(0.75, 0.75), 0.25).x, 0.125, 1e-12);
    EXPECT_NEAR(boxIntegral(g, checker, at(0.3, 0.6), 0.05).x, 0.01, 1e-12);  // inside white texel (1, 1)
    EXPECT_NEAR(boxIntegral(g, checker, at(0.125, 0.125), 0.1).x, 0.0, 1e-12); // inside black texel (0, 3)
    // A uniform disk of diameter 1: area pi / 4 to the drawing's resolution (256 x 256 x 16 subsamples).
    const PatternTable disk = buildPatternTable(nullptr, 0, 0, true);
    EXPECT_NEAR(disk.mean.x, 3.14159265358979 / 4.0, 1e-4);
}

TEST(AreaLightMath, FittedFactorsForAUniformDiskAreThePapers) {
    const AreaFrame<double> f = unitEmitter(true);
    const PatternTable disk = buildPatternTable(nullptr, 0, 0, true);
    const auto t0 = std::chrono::steady_clock::now();
    int n = 0;
    const double alpha = fitRadiusFactor(f, disk, 1.0, 32, &n);
    int nb = 0;
    const double beta = fitRadiusFactor(f, disk, 3.0, 32, &nb);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    std::printf("uniform disk: alpha %.3f (%d samples), beta(n = 3) %.3f (%d samples), %.1f ms\n", alpha, n, beta, nb, ms);
    // Paper 001 section 3 has 0.30 and 0.57 for a uniform disk with its r = alpha |pt|, samples above
    // the centre only and a disk around t. With the paper's model and our samples (also 0.25 and
    // 0.45 diameters off the centre, where alpha must reach further; a square box) alpha is 0.45
    // (measured); with the product's model (OneShotModel) 0.53.
    const double paperAlpha = fitRadiusFactor(f, disk, 1.0, 32, nullptr, OneShotModel::paper());
    std::printf("uniform disk, the paper's model: alpha %.3f\n", paperAlpha);
    EXPECT_NEAR(paperAlpha, 0.45, 0.05);
    EXPECT_GT(n, 100);
    EXPECT_GT(alpha, 0.3);
    EXPECT_LT(alpha, 0.9);
    EXPECT_GT(beta, 0.3);
}

TEST(AreaLightMath, OneShotIsNearTheReferenceForAUniformRectangle) {
    const AreaFrame<double> f = unitEmitter(false);
    const PatternTable uniform = buildPatternTable(nullptr, 0, 0, false);
    for (int variant = 0; variant < 4; ++variant) {
    const OneShotModel model{(variant & 1) != 0, (variant & 2) != 0};
    const double alpha = fitRadiusFactor(f, uniform, 1.0, 32, nullptr, model);
    double beta = 0.0;
    for (double m : BETA_FIT_EXPONENTS) beta += fitRadiusFactor(f, uniform, m, 32, nullptr, model) / 3.0;
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    // A floor 0.5 .. 5 emitter sizes below a ceiling panel, lit downwards; rough dielectric.
    for (double spec : {0.0, 0.5}) {
    for (double h : {0.5, 5.0}) {
        double sumErr = 0.0, sumRef = 0.0;
        for (int i = 0; i < 200; ++i) {
            const V3 p(u(rng) * h, u(rng) * h, h);
            const AreaFrame<double> down = areaFrame<double>({0, 0, 0}, {0, 0, 1}, 0.0, {1, 1}, false);
            const V3 N(0, 0, -1), V = glm::normalize(V3(0.3, 0.2, -1));
            const V3 albedo(0.8);
            const V3 ref = referenceShading(down, uniform, p, N, V, albedo, 0.0, 0.6, spec, 64);
            const V3 one = oneShotShading(down, uniform, p, N, V, albedo, 0.0, 0.6, spec, alpha, beta, model);
            sumErr += std::abs(one.x - ref.x);
            sumRef += ref.x;
        }
        std::printf("clamp %d saturate %d spec %.1f uniform rect, floor at %.1f sizes: alpha %.3f beta %.3f, mean |one-shot - reference| / mean reference %.2f %%\n",
                    int(model.clamp), int(model.saturate), spec, h, alpha, beta, 100.0 * sumErr / sumRef);
        // Measured (mean relative error, rough dielectric / Lambert): the product's model 25 / 36 %
        // at 0.5 sizes and 21 / 24 % at 5; the paper's 24 / 48 % and 48 / 65 %.
        if (model.clamp && model.saturate) {
            EXPECT_LT(sumErr / sumRef, 0.40);
        }
    }
    }
    }
}
