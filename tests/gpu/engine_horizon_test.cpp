// The relight shaders' near-field horizon (common_horizon.glsl) against its C++ definition
// (dfb/lightmath/Horizon.h): a ground plane alone (its shadow map has nothing to cast) given a
// random horizon per sample, lit by a sun and a spot light; the engine's shadow mask must say lit
// exactly where lightmath::horizonLit does. And a shot without a horizon is lit everywhere.

#include "support/FlatMesh.h"
#include "support/ShadowAgreement.h"

#include <dfb/gbuffer/Baker.h>
#include <dfb/lightmath/Horizon.h>
#include <dfb/server/Engine.h>

#include <gtest/gtest.h>

#include <glm/gtc/packing.hpp>

#include <random>

using namespace dfb;

namespace {

float half(float v) { return glm::unpackHalf1x16(glm::packHalf1x16(v)); }

struct Plane {
    Scene scene;
    DeepBuffer shot;
};

Plane groundShot() {
    Plane p;
    std::vector<glm::vec3> ground;
    test::quad(ground, {-5, 0, 5}, {5, 0, 5}, {5, 0, -5}, {-5, 0, -5});
    p.scene.parts = {test::flatPart(1, ground)};
    p.scene.materials.resize(1);
    p.scene.objectNames = {"ground"};
    for (const glm::vec3& v : ground) p.scene.bounds.extend(v);
    BakeOptions o;
    o.width = 96;
    o.height = 54;
    o.lookFrom = glm::vec3(0.f, 4.f, 6.f);
    o.lookAt = glm::vec3(0.f);
    o.horizonRadius = 0.f; // given by hand below
    auto b = bake(p.scene, o);
    EXPECT_TRUE(b.ok()) << b.error().toString();
    if (b.ok()) p.shot = std::move(b.value());
    return p;
}

Light sun() {
    Light l;
    l.name = "sun";
    l.type = LightType::Directional;
    l.direction = {-0.8f, -0.35f, -0.3f}; // 22 degrees above the ground
    l.intensityCd = 3.f;
    l.shadow = true;
    l.shadowFilter = 0;
    return l;
}

Light spot() {
    Light l;
    l.name = "spot";
    l.type = LightType::Spot;
    l.position = {2.f, 2.5f, 1.f};
    l.direction = {-2.f, -2.5f, -1.f};
    l.coneAngleDeg = 80.f;
    l.penumbraDeg = 1.f;
    l.intensityCd = 10.f;
    l.shadow = true;
    l.shadowFilter = 0;
    return l;
}

} // namespace

TEST(EngineHorizon, ShadowMaskFollowsTheHorizonAsTheLightMathDefinesIt) {
    Plane p = groundShot();
    ASSERT_GT(p.shot.sampleCount(), 0u);
    DeepBuffer& g = p.shot;
    ASSERT_FALSE(g.hasHorizon());
    // Random horizons in [0, 0.8], as the engine reads them (half floats).
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.f, 0.8f);
    g.horizon.assign(g.sampleCount() * HORIZON_AZIMUTHS, 0.f);
    for (float& h : g.horizon) h = half(u(rng));
    g.horizonRadius = 0.5f;
    auto engine = Engine::create(g, shadowCasters(p.scene));
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    for (const Light& l : {sun(), spot()}) {
        SCOPED_TRACE(l.name);
        Rig rig;
        rig.lights = {l};
        auto mask = engine.value()->renderShadowMask(rig, l.name);
        ASSERT_TRUE(mask.ok()) << mask.error().toString();
        size_t reached = 0, shadowed = 0, compared = 0, differ = 0;
        test::forEachReachedPixel(mask.value(), g, [&](size_t, size_t s, float vis) {
            ++reached;
            glm::vec3 Ng(half(g.Ng[s * 3]), half(g.Ng[s * 3 + 1]), half(g.Ng[s * 3 + 2]));
            Ng = glm::normalize(Ng);
            const glm::vec3 L = test::towardsLight(l, g.position(s));
            const float* h = &g.horizon[s * HORIZON_AZIMUTHS];
            // Within rounding of the boundary either answer is right.
            if (std::abs(glm::dot(Ng, L) - lightmath::horizonSine(h, Ng, L)) < 1e-3f) return;
            ++compared;
            const bool want = lightmath::horizonLit(h, Ng, L), lit = vis >= 0.5f;
            differ += want != lit;
            shadowed += !lit;
        });
        std::printf("%s: %zu reached, %zu compared, %zu shadowed by the horizon, %zu differ\n", l.name.c_str(), reached,
                    compared, shadowed, differ);
        EXPECT_GT(compared, reached * 9 / 10);
        EXPECT_GT(shadowed, compared / 10) << "the random horizons should shadow a good part";
        EXPECT_LT(shadowed, compared * 9 / 10);
        EXPECT_EQ(differ, 0u);
    }
    // Without the horizon the same shot is lit wherever the light reaches.
    g.horizon.clear();
    g.horizonRadius = 0.f;
    auto bare = Engine::create(g, shadowCasters(p.scene));
    ASSERT_TRUE(bare.ok()) << bare.error().toString();
    Rig rig;
    rig.lights = {sun()};
    auto mask = bare.value()->renderShadowMask(rig, "sun");
    ASSERT_TRUE(mask.ok()) << mask.error().toString();
    size_t reached = 0, shadowed = 0;
    test::forEachReachedPixel(mask.value(), g, [&](size_t, size_t, float vis) {
        ++reached;
        shadowed += vis < 0.5f;
    });
    EXPECT_GT(reached, 1000u);
    EXPECT_EQ(shadowed, 0u);
}
