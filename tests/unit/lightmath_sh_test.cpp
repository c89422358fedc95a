// Real spherical harmonics of any order (lightmath/SphericalHarmonics.h, shEvaluateBands): the
// engine's nine for bands 0-2, orthonormal over the sphere, and each band's addition theorem.

#include <dfb/lightmath/Environment.h>
#include <dfb/lightmath/SphericalHarmonics.h>

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>
#include <vector>

namespace {

namespace lm = dfb::lightmath;
constexpr double PI = 3.14159265358979323846;

std::vector<glm::dvec3> randomDirections(size_t n) {
    std::mt19937 rng(7);
    std::normal_distribution<double> g;
    std::vector<glm::dvec3> out;
    while (out.size() < n) {
        const glm::dvec3 d(g(rng), g(rng), g(rng));
        if (glm::length(d) > 1e-6) out.push_back(glm::normalize(d));
    }
    // The poles and the equator, where the recurrences' sin theta and atan2 are at their limits.
    out.push_back({0, 0, 1});
    out.push_back({0, 0, -1});
    out.push_back({1, 0, 0});
    return out;
}

TEST(SphericalHarmonics, FirstThreeBandsAreTheEnginesNine) {
    for (const glm::dvec3& d : randomDirections(200)) {
        double y[lm::SH_MAX_BANDS * lm::SH_MAX_BANDS];
        lm::shEvaluateBands(d, 3, y);
        const auto nine = lm::shEvaluate(d);
        for (int i = 0; i < lm::SH_COEFFICIENTS; ++i) EXPECT_NEAR(y[i], nine[size_t(i)], 1e-12) << "coefficient " << i;
    }
}

TEST(SphericalHarmonics, FirstFiveBandsAreTheTransfersTwentyFive) {
    // shEvaluate25's polynomials (and common_env.glsl's copy) against the recurrences.
    for (const glm::dvec3& d : randomDirections(200)) {
        double y[lm::SH_MAX_BANDS * lm::SH_MAX_BANDS];
        lm::shEvaluateBands(d, lm::SH_TRANSFER_BANDS, y);
        const auto all = lm::shEvaluate25(d);
        for (int i = 0; i < lm::SH_TRANSFER_COEFFICIENTS; ++i) EXPECT_NEAR(y[i], all[size_t(i)], 1e-12) << "coefficient " << i;
    }
}

TEST(SphericalHarmonics, UnshadowedTransferIsTheClampedCosinesProjection) {
    // T_i = (1/pi) integral of max(0, N.w) Y_i(w) dw by quadrature, against the band factors
    // 1, 2/3, 1/4, 0, -1/24 (Ramamoorthi and Hanrahan 2001, eq. 8) times Y_i(N), for tilted normals.
    constexpr int ROWS = 600, COLS = 1200;
    const double dOmega = 4 * PI / (ROWS * COLS);
    for (const glm::dvec3& N : {glm::dvec3(0, 0, 1), glm::normalize(glm::dvec3(0.3, -0.5, 0.8)), glm::normalize(glm::dvec3(-0.7, 0.2, -0.1))}) {
        std::array<double, lm::SH_TRANSFER_COEFFICIENTS> t{};
        for (int j = 0; j < ROWS; ++j) {
            const double z = 1.0 - 2.0 * (j + 0.5) / ROWS, s = std::sqrt(1 - z * z);
            for (int i = 0; i < COLS; ++i) {
                const double phi = 2 * PI * (i + 0.5) / COLS;
                const glm::dvec3 w(s * std::cos(phi), s * std::sin(phi), z);
                const double c = glm::dot(N, w);
                if (c <= 0) continue;
                const auto y = lm::shEvaluate25(w);
                for (int k = 0; k < lm::SH_TRANSFER_COEFFICIENTS; ++k) t[size_t(k)] += c * y[size_t(k)] * dOmega / PI;
            }
        }
        const auto expected = lm::shUnshadowedTransfer25(N);
        const auto nine = lm::shUnshadowedTransfer(N);
        for (int k = 0; k < lm::SH_TRANSFER_COEFFICIENTS; ++k) {
            EXPECT_NEAR(t[size_t(k)], expected[size_t(k)], 2e-4) << "coefficient " << k;
            if (k < lm::SH_COEFFICIENTS) {
                EXPECT_DOUBLE_EQ(nine[size_t(k)], expected[size_t(k)]) << "coefficient " << k;
            }
        }
    }
}

TEST(SphericalHarmonics, EachBandKeepsTheAdditionTheorem) {
    // sum over m of Y_lm(d)^2 = (2l + 1) / (4 pi) at every direction: every coefficient's
    // normalisation, whichever m, without a quadrature.
    for (const glm::dvec3& d : randomDirections(200)) {
        double y[lm::SH_MAX_BANDS * lm::SH_MAX_BANDS];
        lm::shEvaluateBands(d, lm::SH_MAX_BANDS, y);
        for (int l = 0; l < lm::SH_MAX_BANDS; ++l) {
            double sum = 0;
            for (int m = -l; m <= l; ++m) sum += y[l * (l + 1) + m] * y[l * (l + 1) + m];
            EXPECT_NEAR(sum, (2 * l + 1) / (4 * PI), 1e-10) << "band " << l;
        }
    }
}

TEST(SphericalHarmonics, AreOrthonormalOverTheSphere) {
    // Gauss-free midpoint quadrature on a fine latitude-longitude grid (z = cos theta uniform in
    // rows: the rows' solid angles are equal): good to 1e-4 for these polynomials of degree <= 14.
    constexpr int B = 8, K = B * B, ROWS = 400, COLS = 800;
    std::vector<double> gram(size_t(K * K), 0.0);
    double y[K];
    const double dOmega = 4 * PI / (ROWS * COLS);
    for (int j = 0; j < ROWS; ++j) {
        const double z = 1.0 - 2.0 * (j + 0.5) / ROWS, s = std::sqrt(1 - z * z);
        for (int i = 0; i < COLS; ++i) {
            const double phi = 2 * PI * (i + 0.5) / COLS;
            lm::shEvaluateBands(glm::dvec3(s * std::cos(phi), s * std::sin(phi), z), B, y);
            for (int a = 0; a < K; ++a)
                for (int b = a; b < K; ++b) gram[size_t(a * K + b)] += y[a] * y[b] * dOmega;
        }
    }
    for (int a = 0; a < K; ++a)
        for (int b = a; b < K; ++b) EXPECT_NEAR(gram[size_t(a * K + b)], a == b ? 1.0 : 0.0, 1e-3) << a << ", " << b;
}

// The five bands' rotation (shRotation25) turns a map's coefficients exactly as projecting the
// turned map does (envProjectSh, what the engine did at every rotation), for rotations about
// every axis, and keeps each band's energy (its block is orthogonal).
TEST(SphericalHarmonics, RotatingTheCoefficientsIsProjectingTheTurnedMap) {
    constexpr int W = 64, H = 32;
    std::vector<float> map(size_t(W * H * 4), 1.f);
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.f, 4.f);
    for (size_t i = 0; i < map.size(); ++i) map[i] = u(rng);
    // A bright spot: high frequencies that the coefficients must carry as projected.
    for (int j = 5; j < 9; ++j)
        for (int i = 20; i < 26; ++i) map[size_t((j * W + i) * 4 + 1)] = 300.f;
    const auto L = lm::envProjectSh(map.data(), W, H, 4, glm::dmat3(1.0));
    for (const std::array<float, 3>& ypr : {std::array<float, 3>{37.f, 0.f, 0.f}, {0.f, -71.f, 0.f}, {0.f, 0.f, 128.f},
                                             {-160.f, 45.f, 10.f}, {300.f, -89.f, 179.f}}) {
        const glm::dmat3 R = lm::envRotation(ypr);
        const auto want = lm::envProjectSh(map.data(), W, H, 4, R);
        const auto got = lm::shRotate25(L, R);
        double scale = 0;
        for (const glm::dvec3& c : want) scale = std::max(scale, glm::length(c));
        for (int i = 0; i < lm::SH_TRANSFER_COEFFICIENTS; ++i)
            for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[size_t(i)][c], want[size_t(i)][c], 1e-9 * scale) << i << ", " << c;
        for (int band = 0; band < lm::SH_TRANSFER_BANDS; ++band) {
            double before = 0, after = 0;
            for (int i = band * band; i < (band + 1) * (band + 1); ++i) {
                before += L[size_t(i)].y * L[size_t(i)].y;
                after += got[size_t(i)].y * got[size_t(i)].y;
            }
            EXPECT_NEAR(after, before, 1e-9 * before) << band;
        }
    }
}

} // namespace

// The engine's prefiltered environment is a cube map (EnvironmentMap.h): a face's texel direction
// (cubeDirection) is where OpenGL's face selection (cubeFace, the specification's table 8.19)
// sends it back, and each face's centre is its axis.
TEST(EnvironmentCube, FaceDirectionsInvertOpenGLsSelection) {
    const glm::dvec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (int f = 0; f < 6; ++f) EXPECT_LT(glm::length(lm::cubeDirection(f, 0.5, 0.5) - axes[f]), 1e-12) << f;
    std::mt19937 rng(7);
    std::normal_distribution<double> g;
    for (int k = 0; k < 10000; ++k) {
        const glm::dvec3 d = glm::normalize(glm::dvec3(g(rng), g(rng), g(rng)));
        glm::dvec2 st;
        const int face = lm::cubeFace(d, st);
        ASSERT_GE(face, 0);
        ASSERT_LT(face, 6);
        ASSERT_GE(std::min(st.x, st.y), 0.0);
        ASSERT_LE(std::max(st.x, st.y), 1.0);
        ASSERT_LT(glm::length(lm::cubeDirection(face, st.x, st.y) - d), 1e-12) << k;
        ASSERT_GT(glm::dot(d, axes[face]), 0.57) << "the face of the direction's largest component";
    }
}
