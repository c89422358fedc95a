// The near-field horizon's math (dfb/lightmath/Horizon.h): the frame its azimuths are measured
// in, the interpolation between them and the lit test. Its GLSL mirror is held to it by
// tests/gpu/engine_horizon_test.cpp.

#include <dfb/lightmath/Horizon.h>

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

using namespace dfb::lightmath;

namespace {

glm::vec3 randomUnit(std::mt19937& rng) {
    std::normal_distribution<float> g;
    for (;;) {
        const glm::vec3 v(g(rng), g(rng), g(rng));
        if (glm::length(v) > 1e-3f) return glm::normalize(v);
    }
}

} // namespace

TEST(Horizon, FrameIsOrthonormalAndRightHandedAboutEveryNormal) {
    std::mt19937 rng(1);
    std::vector<glm::vec3> normals = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {1, 0, -0.f}, {0.6f, 0.8f, 0.f}};
    for (int i = 0; i < 1000; ++i) normals.push_back(randomUnit(rng));
    for (const glm::vec3& n : normals) {
        glm::vec3 t, b;
        horizonFrame(n, t, b);
        EXPECT_NEAR(glm::length(t), 1.f, 1e-5f);
        EXPECT_NEAR(glm::length(b), 1.f, 1e-5f);
        EXPECT_NEAR(glm::dot(t, n), 0.f, 1e-5f);
        EXPECT_NEAR(glm::dot(b, n), 0.f, 1e-5f);
        EXPECT_NEAR(glm::dot(t, b), 0.f, 1e-5f);
        EXPECT_NEAR(glm::dot(glm::cross(t, b), n), 1.f, 1e-5f); // right-handed: azimuths turn about n
    }
    // -0 and +0 take the same branch (the bake and the shader must agree on the frame).
    glm::vec3 t0, b0, t1, b1;
    horizonFrame(glm::vec3(0.6f, 0.8f, 0.f), t0, b0);
    horizonFrame(glm::vec3(0.6f, 0.8f, -0.f), t1, b1);
    EXPECT_EQ(t0, t1);
    EXPECT_EQ(b0, b1);
}

TEST(Horizon, SineIsTheStoredValueAtEachAzimuthAndLinearBetween) {
    std::mt19937 rng(2);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    for (int trial = 0; trial < 50; ++trial) {
        const glm::vec3 n = randomUnit(rng);
        glm::vec3 t, b;
        horizonFrame(n, t, b);
        std::array<float, HORIZON_AZIMUTHS> h;
        for (float& v : h) v = u(rng);
        for (int k = 0; k < HORIZON_AZIMUTHS; ++k) {
            // Any elevation towards azimuth k reads h[k]; half-way to k + 1 the mean of both.
            const float s = u(rng) * 0.99f;
            EXPECT_NEAR(horizonSine(h.data(), n, horizonDirection(n, t, b, k, s)), h[size_t(k)], 1e-4f) << k;
            const float phi = 2.f * 3.14159265f * (float(k) + 0.5f) / float(HORIZON_AZIMUTHS);
            const glm::vec3 mid = glm::normalize(std::cos(phi) * t + std::sin(phi) * b + 0.3f * n);
            EXPECT_NEAR(horizonSine(h.data(), n, mid), 0.5f * (h[size_t(k)] + h[size_t(k + 1) % HORIZON_AZIMUTHS]), 1e-4f) << k;
        }
        EXPECT_TRUE(horizonLit(h.data(), n, n)); // straight up: above every horizon short of 1
    }
}

TEST(Horizon, LitAboveTheHorizonAndTheGeometricPlaneOnly) {
    const glm::vec3 n(0, 1, 0);
    glm::vec3 t, b;
    horizonFrame(n, t, b);
    std::array<float, HORIZON_AZIMUTHS> open{}, wall{};
    wall[4] = 0.5f; // 30 degrees towards azimuth 4 only
    const glm::vec3 low = horizonDirection(n, t, b, 4, 0.4f), high = horizonDirection(n, t, b, 4, 0.6f);
    EXPECT_TRUE(horizonLit(open.data(), n, low));
    EXPECT_FALSE(horizonLit(wall.data(), n, low));
    EXPECT_TRUE(horizonLit(wall.data(), n, high));
    EXPECT_TRUE(horizonLit(wall.data(), n, horizonDirection(n, t, b, 12, 0.1f))); // the other side
    EXPECT_FALSE(horizonLit(open.data(), n, glm::vec3(0, -1, 0)));                // below the plane
    EXPECT_FALSE(horizonLit(open.data(), n, glm::normalize(glm::vec3(1, 0, 0)))); // in the plane
}
