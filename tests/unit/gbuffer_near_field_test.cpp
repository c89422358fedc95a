// The near-field horizon's bake (dfb/gbuffer/NearField.h): traced against hand-made scenes whose
// horizons are known in closed form, the escape of a sample that starts inside a mesh, and the
// refusal of bad reaches.

#include "support/FlatMesh.h"

#include <dfb/gbuffer/NearField.h>
#include <dfb/lightmath/Horizon.h>

#include <gtest/gtest.h>

#include <cmath>

using namespace dfb;

namespace {

// A scene of flat parts, its bounds from their corners.
Scene sceneOf(std::vector<MeshPart> parts) {
    Scene s;
    s.parts = std::move(parts);
    for (const MeshPart& p : s.parts)
        for (const glm::vec3& v : p.positions) s.bounds.extend(v);
    return s;
}

// A one-pixel buffer holding one covered sample at P with geometric (and shading) normal n.
DeepBuffer oneSample(const glm::vec3& P, const glm::vec3& n) {
    DeepBuffer b;
    b.allocate(1, 1);
    for (int c = 0; c < 3; ++c) {
        b.P[size_t(c)] = P[c];
        b.N[size_t(c)] = n[c];
        b.Ng[size_t(c)] = n[c];
    }
    b.A[0] = 1.f;
    return b;
}

// The azimuth index whose direction (elevation 0) is closest to the horizontal direction d.
int azimuthTowards(const glm::vec3& n, const glm::vec3& d) {
    glm::vec3 t, b;
    lightmath::horizonFrame(n, t, b);
    int best = 0;
    for (int k = 1; k < HORIZON_AZIMUTHS; ++k)
        if (glm::dot(lightmath::horizonDirection(n, t, b, k, 0.f), d) > glm::dot(lightmath::horizonDirection(n, t, b, best, 0.f), d))
            best = k;
    return best;
}

} // namespace

// A ground (y = 0, 40 x 40) and a wall of height 1 at x = 1 across z: from the origin the wall
// rises to sin(e) = 1 / sqrt(2) towards +x (within the reach, 4 units), nothing elsewhere.
TEST(NearField, HorizonOfAWallMatchesItsElevation) {
    std::vector<glm::vec3> ground, wall;
    test::quad(ground, {-20, 0, 20}, {20, 0, 20}, {20, 0, -20}, {-20, 0, -20});
    test::quad(wall, {1, 0, 20}, {1, 0, -20}, {1, 1, -20}, {1, 1, 20}); // facing -x
    Scene scene = sceneOf({test::flatPart(1, ground), test::flatPart(2, wall)});
    const float radius = scene.bounds.radius();
    DeepBuffer b = oneSample({0, 0, 0}, {0, 1, 0});
    auto st = bakeHorizon(scene, b, 4.f / radius);
    ASSERT_TRUE(st.ok()) << st.error().toString();
    ASSERT_TRUE(b.hasHorizon());
    EXPECT_NEAR(b.horizonRadius, 4.f, 1e-4f);
    EXPECT_EQ(st->samples, 1u);
    const glm::vec3 n(0, 1, 0);
    glm::vec3 t, bt;
    lightmath::horizonFrame(n, t, bt);
    for (int k = 0; k < HORIZON_AZIMUTHS; ++k) {
        const glm::vec3 d = lightmath::horizonDirection(n, t, bt, k, 0.f);
        // Along azimuth k the wall is 1 / d.x away (when ahead and within reach), 1 high.
        float want = 0.f;
        if (d.x > 1e-3f) {
            const float dist = 1.f / d.x;
            // The highest point within the reach: the top edge, or where the reach ends on the wall.
            const float top = std::min(1.f, std::sqrt(std::max(0.f, 16.f - dist * dist)));
            if (dist < 4.f) want = top / std::sqrt(top * top + dist * dist);
        }
        EXPECT_NEAR(b.horizon[size_t(k)], want, 1.f / 128.f) << "azimuth " << k;
    }
    EXPECT_NEAR(b.horizon[size_t(azimuthTowards(n, {1, 0, 0}))], std::sqrt(0.5f), 1.f / 128.f);
    // And the horizon closes the light behind the wall's top, not above it.
    const glm::vec3 under = glm::normalize(glm::vec3(1.f, 0.9f, 0.f)), over = glm::normalize(glm::vec3(1.f, 1.1f, 0.f));
    EXPECT_FALSE(lightmath::horizonLit(b.horizon.data(), n, under));
    EXPECT_TRUE(lightmath::horizonLit(b.horizon.data(), n, over));
}

// The same wall past the reach leaves the horizon open.
TEST(NearField, OccludersPastTheReachAreLeftToTheShadowMap) {
    std::vector<glm::vec3> ground, wall;
    test::quad(ground, {-20, 0, 20}, {20, 0, 20}, {20, 0, -20}, {-20, 0, -20});
    test::quad(wall, {1, 0, 20}, {1, 0, -20}, {1, 1, -20}, {1, 1, 20});
    Scene scene = sceneOf({test::flatPart(1, ground), test::flatPart(2, wall)});
    DeepBuffer b = oneSample({0, 0, 0}, {0, 1, 0});
    ASSERT_TRUE(bakeHorizon(scene, b, 0.5f / scene.bounds.radius()).ok());
    for (int k = 0; k < HORIZON_AZIMUTHS; ++k) EXPECT_EQ(b.horizon[size_t(k)], 0.f) << k;
}

// A sample whose position lies just inside a closed box (a merged sample's averaged position on
// a convex corner) starts its rays past the box's face it would leave through, instead of
// finding everything closed.
TEST(NearField, ASampleInsideAMeshStartsPastItsSurface) {
    std::vector<glm::vec3> box;
    const glm::vec3 lo(-1, -1, -1), hi(1, 1, 1);
    test::quad(box, {lo.x, hi.y, hi.z}, {hi.x, hi.y, hi.z}, {hi.x, hi.y, lo.z}, {lo.x, hi.y, lo.z}); // top, +y
    test::quad(box, {lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, lo.y, hi.z}, {lo.x, lo.y, hi.z}); // bottom, -y
    test::quad(box, {hi.x, lo.y, hi.z}, {hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z}, {hi.x, hi.y, hi.z}); // +x
    test::quad(box, {lo.x, lo.y, lo.z}, {lo.x, lo.y, hi.z}, {lo.x, hi.y, hi.z}, {lo.x, hi.y, lo.z}); // -x
    test::quad(box, {lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z}); // +z
    test::quad(box, {hi.x, lo.y, lo.z}, {lo.x, lo.y, lo.z}, {lo.x, hi.y, lo.z}, {hi.x, hi.y, lo.z}); // -z
    Scene scene = sceneOf({test::flatPart(1, box)});
    // On the top face's corner with +x, 0.01 inside, its normal half-way between the two faces.
    DeepBuffer b = oneSample({0.99f, 0.99f, 0.f}, glm::normalize(glm::vec3(1, 1, 0)));
    ASSERT_TRUE(bakeHorizon(scene, b, 0.2f).ok());
    // Outside the corner the box lies below 45 degrees on both sides: towards +y's side of the
    // corner (azimuth along -x, across the top) the top face closes up to 45 degrees, no more.
    int closed = 0;
    for (int k = 0; k < HORIZON_AZIMUTHS; ++k) {
        EXPECT_LE(b.horizon[size_t(k)], std::sqrt(0.5f) + 1.f / 64.f) << k;
        closed += b.horizon[size_t(k)] >= 1.f;
    }
    EXPECT_EQ(closed, 0);
}

TEST(NearField, BadReachOrBufferIsRefusedAndChangesNothing) {
    std::vector<glm::vec3> ground;
    test::quad(ground, {-1, 0, 1}, {1, 0, 1}, {1, 0, -1}, {-1, 0, -1});
    Scene scene = sceneOf({test::flatPart(1, ground)});
    for (float r : {0.f, -0.1f, MAX_HORIZON_RADIUS_FRACTION * 1.01f, std::nanf("")}) {
        DeepBuffer b = oneSample({0, 0, 0}, {0, 1, 0});
        auto st = bakeHorizon(scene, b, r);
        ASSERT_FALSE(st.ok()) << r;
        EXPECT_EQ(st.error().code, ErrorCode::InvalidValue);
        EXPECT_NE(st.error().message.find("near-field horizon radius"), std::string::npos) << st.error().message;
        EXPECT_FALSE(b.hasHorizon());
    }
    DeepBuffer broken = oneSample({0, 0, 0}, {0, 1, 0});
    broken.Ng.clear();
    auto st = bakeHorizon(scene, broken, 0.1f);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error().message.find("inconsistent"), std::string::npos) << st.error().message;
    EXPECT_FALSE(broken.hasHorizon());
}
