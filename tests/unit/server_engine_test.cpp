// The relight engine through real EGL: a Lambertian plane under a spot light matches the closed
// form, shadows darken what is behind a blocker, and the cache re-renders only what changed.

#include <dfb/gbuffer/Scene.h>
#include <dfb/server/Engine.h>

#include <gtest/gtest.h>

#include <cmath>
#include <glm/gtc/matrix_transform.hpp>

using namespace dfb;

namespace {

// A 64x64 shot looking straight down at the plane y = 0, covering x, z in [-2, 2].
DeepBuffer planeShot(float albedo) {
    DeepBuffer b;
    b.allocate(64, 64);
    for (int y = 0; y < 64; ++y)
        for (int x = 0; x < 64; ++x) {
            const size_t i = size_t(y) * 64 + x;
            b.P[i * 3 + 0] = -2.f + 4.f * (x + 0.5f) / 64.f;
            b.P[i * 3 + 1] = 0.f;
            b.P[i * 3 + 2] = -2.f + 4.f * (y + 0.5f) / 64.f;
            b.N[i * 3 + 1] = 1.f;
            b.Ng[i * 3 + 1] = 1.f;
            for (int c = 0; c < 3; ++c) b.albedo[i * 3 + c] = albedo;
            b.brdf[i * 4 + 0] = 0.f; // dielectric
            b.brdf[i * 4 + 1] = 1.f; // fully rough
            b.brdf[i * 4 + 2] = 0.f; // no specular: a pure Lambertian surface
            b.brdf[i * 4 + 3] = 1.f;
            b.A[i] = 1.f;
            b.objectId[i] = 1;
        }
    b.camera.worldToCamera = glm::lookAt(glm::vec3(0, 10, 0), glm::vec3(0), glm::vec3(0, 0, -1));
    return b;
}

double srgbToLinear(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

Rig spotRig() {
    Rig rig;
    Light l;
    l.name = "key";
    l.position = {0.3f, 2.f, -0.2f};
    l.direction = {0.f, -1.f, 0.f};
    l.intensityCd = 6.f;
    l.coneAngleDeg = 70.f;
    l.penumbraDeg = 0.5f;
    l.shadow = false;
    rig.lights.push_back(l);
    return rig;
}

} // namespace

TEST(Engine, LambertPlaneMatchesClosedForm) {
    const float albedo = 0.5f;
    auto engine = Engine::create(planeShot(albedo), ShadowGeometry{});
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    const Rig rig = spotRig();
    auto img = engine.value()->render(rig);
    ASSERT_TRUE(img.ok()) << img.error().toString();
    const Light& l = rig.lights[0];
    int checked = 0;
    for (int y = 4; y < 64; y += 8)
        for (int x = 4; x < 64; x += 8) {
            const glm::vec3 p(-2.f + 4.f * (x + 0.5f) / 64.f, 0.f, -2.f + 4.f * (y + 0.5f) / 64.f);
            const glm::vec3 toLight = glm::vec3(l.position[0], l.position[1], l.position[2]) - p;
            const float d = glm::length(toLight);
            const float cosTheta = toLight.y / d;
            // Inside the cone's full-intensity core only.
            if (std::acos(cosTheta) > glm::radians(l.coneAngleDeg - l.penumbraDeg - 2.f)) continue;
            const double expected = albedo / M_PI * l.intensityCd * cosTheta / (d * d);
            if (expected > 0.95) continue; // clipped by the 8-bit output
            const double got = srgbToLinear(img->rgba[(size_t(y) * 64 + x) * 4] / 255.0);
            // 8-bit sRGB quantisation: half a code value is at most ~1.5% of the value above 0.05.
            EXPECT_NEAR(got, expected, 0.015 * expected + 0.002) << "pixel " << x << "," << y;
            ++checked;
        }
    EXPECT_GT(checked, 20);
}

TEST(Engine, LambertPlaneMatchesClosedFormWithinOnePercentInLinearOutput) {
    // Issue 5's numeric check on the float output (no 8-bit quantisation): every lit pixel of a
    // Lambertian plane equals albedo / pi * I * cos(theta) / d^2 within 1%.
    const float albedo = 0.5f;
    auto engine = Engine::create(planeShot(albedo), ShadowGeometry{});
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    const Rig rig = spotRig();
    auto img = engine.value()->renderLinear(rig);
    ASSERT_TRUE(img.ok()) << img.error().toString();
    const Light& l = rig.lights[0];
    double worst = 0;
    int checked = 0;
    for (int y = 0; y < 64; ++y)
        for (int x = 0; x < 64; ++x) {
            const glm::vec3 p(-2.f + 4.f * (x + 0.5f) / 64.f, 0.f, -2.f + 4.f * (y + 0.5f) / 64.f);
            const glm::vec3 toLight = glm::vec3(l.position[0], l.position[1], l.position[2]) - p;
            const float d = glm::length(toLight);
            const float cosTheta = toLight.y / d;
            if (std::acos(cosTheta) > glm::radians(l.coneAngleDeg - l.penumbraDeg - 1.f)) continue;
            const double expected = albedo / M_PI * l.intensityCd * cosTheta / (d * d);
            const double got = img->rgba[(size_t(y) * 64 + x) * 4];
            worst = std::max(worst, std::abs(got - expected) / expected);
            ++checked;
        }
    std::printf("Lambert plane: %d pixels, worst relative error %.2e\n", checked, worst);
    EXPECT_GT(checked, 1000);
    EXPECT_LT(worst, 0.01);
}

TEST(Engine, DirectionalLightIsParallelInLuxAndCastsShadows) {
    // A sun at 60 degrees from the zenith over the Lambertian plane, with a square blocker 1 unit
    // above the centre: radiance albedo / pi * E * cos(theta) everywhere lit, and the blocker's
    // shadow displaced by tan(60) along the light's horizontal direction.
    ShadowGeometry g;
    g.positions = {{-0.25f, 1.f, -0.25f}, {0.25f, 1.f, -0.25f}, {0.25f, 1.f, 0.25f}, {-0.25f, 1.f, 0.25f}};
    g.indices = {0, 1, 2, 0, 2, 3};
    const float albedo = 0.5f;
    auto engine = Engine::create(planeShot(albedo), g);
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    Rig rig;
    Light sun;
    sun.name = "sun";
    sun.type = LightType::Directional;
    const float theta = glm::radians(60.f);
    sun.direction = {std::sin(theta), -std::cos(theta), 0.f}; // travelling towards +x, downwards
    sun.intensityCd = 3.f;                                     // lux
    sun.shadowMapSize = 1024;
    rig.lights.push_back(sun);
    auto img = engine.value()->renderLinear(rig);
    ASSERT_TRUE(img.ok()) << img.error().toString();
    auto at = [&](float wx, float wz) {
        const int x = int((wx + 2.f) / 4.f * 64.f), y = int((wz + 2.f) / 4.f * 64.f);
        return double(img->rgba[(size_t(y) * 64 + x) * 4]);
    };
    const double expected = albedo / M_PI * 3.0 * std::cos(theta);
    EXPECT_NEAR(at(-1.5f, 1.5f), expected, 0.01 * expected);
    EXPECT_NEAR(at(-1.5f, -1.5f), expected, 0.01 * expected);
    // The shadow of the square lands at x in [-0.25, 0.25] + tan(60) = [1.48, 1.98], z in [-0.25, 0.25].
    EXPECT_LT(at(1.73f, 0.f), 0.05 * expected);
    EXPECT_NEAR(at(0.f, 0.f), expected, 0.01 * expected); // right under the blocker: lit (oblique sun)
}

TEST(Engine, BlockerCastsAShadowOnlyWhereExpected) {
    // A small square blocker 1 unit above the plane, under a light straight above it.
    ShadowGeometry g;
    g.positions = {{-0.25f, 1.f, -0.25f}, {0.25f, 1.f, -0.25f}, {0.25f, 1.f, 0.25f}, {-0.25f, 1.f, 0.25f}};
    g.indices = {0, 1, 2, 0, 2, 3};
    auto engine = Engine::create(planeShot(0.5f), g);
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    Rig rig = spotRig();
    rig.lights[0].position = {0.f, 2.f, 0.f};
    rig.lights[0].shadow = true;
    auto img = engine.value()->render(rig);
    ASSERT_TRUE(img.ok()) << img.error().toString();
    auto at = [&](float wx, float wz) {
        const int x = int((wx + 2.f) / 4.f * 64.f), y = int((wz + 2.f) / 4.f * 64.f);
        return img->rgba[(size_t(y) * 64 + x) * 4];
    };
    // The shadow of a 0.5 square at height 1 from height 2 is a 1.0 square on the plane.
    EXPECT_LT(at(0.f, 0.f), 5) << "centre of the shadow must be dark";
    EXPECT_LT(at(0.4f, 0.4f), 5) << "inside the projected shadow";
    EXPECT_GT(at(0.7f, 0.7f), 100) << "outside the projected shadow";
    EXPECT_GT(at(-0.7f, 0.f), 100);
}

TEST(Engine, CacheRerendersOnlyWhatChanged) {
    ShadowGeometry g;
    g.positions = {{-0.25f, 1.f, -0.25f}, {0.25f, 1.f, -0.25f}, {0.25f, 1.f, 0.25f}};
    g.indices = {0, 1, 2};
    auto engine = Engine::create(planeShot(0.5f), g);
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    Rig rig = spotRig();
    rig.lights[0].shadow = true;
    Light fill = rig.lights[0];
    fill.name = "fill";
    fill.position = {-1.f, 2.f, 0.f};
    rig.lights.push_back(fill);
    FrameStats st;
    ASSERT_TRUE(engine.value()->render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 2);
    EXPECT_EQ(st.lightsShaded, 2);
    ASSERT_TRUE(engine.value()->render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 0);
    EXPECT_EQ(st.lightsShaded, 0);
    rig.lights[1].intensityCd *= 2.f; // a rescale of the cached contribution only
    rig.lights[1].color = {1.f, 0.5f, 0.25f};
    ASSERT_TRUE(engine.value()->render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 0);
    EXPECT_EQ(st.lightsShaded, 0);
    rig.lights[1].penumbraDeg = 10.f; // shading only
    ASSERT_TRUE(engine.value()->render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 0);
    EXPECT_EQ(st.lightsShaded, 1);
    rig.lights[0].coneAngleDeg = 72.f; // 70 -> 72: the shadow frustum (cone + 1, rounded up to 5: 75) stays
    ASSERT_TRUE(engine.value()->render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 0);
    EXPECT_EQ(st.lightsShaded, 1);
    rig.lights[0].position[0] += 0.1f; // shadow map and shading of that light only
    ASSERT_TRUE(engine.value()->render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 1);
    EXPECT_EQ(st.lightsShaded, 1);
}

// ---- Closed casters (shadow maps cull their front faces) ----

namespace {
// A unit cube: 8 corners, 12 counter-clockwise (outward) triangles.
void cube(std::vector<glm::vec3>& p, std::vector<uint32_t>& idx) {
    p.clear();
    for (int i = 0; i < 8; ++i) p.emplace_back(float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1));
    idx = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
}
} // namespace

TEST(ShadowCasters, ClosedMeshesAreRecognisedAndOpenOrInconsistentOnesAreNot) {
    std::vector<glm::vec3> p;
    std::vector<uint32_t> idx;
    cube(p, idx);
    EXPECT_TRUE(isClosedMesh(p, idx));
    // Split vertices (every triangle its own corners, as at UV seams) are welded by position.
    std::vector<glm::vec3> split;
    std::vector<uint32_t> splitIdx;
    for (uint32_t i : idx) {
        splitIdx.push_back(uint32_t(split.size()));
        split.push_back(p[i]);
    }
    EXPECT_TRUE(isClosedMesh(split, splitIdx));
    // A missing face leaves a hole.
    std::vector<uint32_t> holed(idx.begin(), idx.end() - 6);
    EXPECT_FALSE(isClosedMesh(p, holed));
    // One triangle wound the other way: closed, but not consistently oriented.
    std::vector<uint32_t> flipped = idx;
    std::swap(flipped[1], flipped[2]);
    EXPECT_FALSE(isClosedMesh(p, flipped));
    // A single quad (a floor) is open; out-of-range indices are not a mesh.
    EXPECT_FALSE(isClosedMesh(p, {0, 1, 2, 1, 3, 2}));
    EXPECT_FALSE(isClosedMesh(p, {0, 1, 99}));
}

TEST(ShadowCasters, TheDefaultSceneSortsClosedPartsFirst) {
    auto scene = loadScene(DFB_SOURCE_DIR "/scenes/tabletop.glb");
    ASSERT_TRUE(scene.ok()) << scene.error().toString();
    const ShadowGeometry g = shadowCasters(scene.value());
    size_t closedParts = 0, closedIndices = 0;
    for (const MeshPart& part : scene->parts) {
        const bool closed = isClosedMesh(part.positions, part.indices);
        std::printf("part object %u: %zu triangles, %s\n", part.objectId, part.indices.size() / 3, closed ? "closed" : "open");
        closedParts += closed;
        closedIndices += closed ? part.indices.size() : 0;
    }
    EXPECT_GT(closedParts, 0u);
    EXPECT_EQ(g.closedIndexCount, closedIndices);
    EXPECT_EQ(g.indices.size(), scene->triangleCount() * 3);
}
