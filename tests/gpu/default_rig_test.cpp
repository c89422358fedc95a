// The rig a session starts with when its scene brings no lights (issue 19 point 6; docs/
// lighting.md, "Default rig"): every asset scene of the test set, baked without a camera (auto
// framing) at 160 x 90 with the environment transfer, gets sessionRig's three-point rig and dome,
// and rendered by an engine of its own its covered pixels' median luminance is within a factor 2
// of mid-grey (0.18) with at most 5 % of them black (luminance below 1/100 of mid-grey, 0.0018:
// 6 of 255 after sRGB encoding). The layout is checked against the camera: key and fill on the
// camera's side, the rim behind the subject.

#include <dfb/gbuffer/Baker.h>
#include <dfb/gbuffer/Scene.h>
#include <dfb/server/Engine.h>
#include <dfb/server/InitialRig.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

using namespace dfb;

namespace {

struct ShotLevels {
    double p50 = 0;
    double blackFraction = 1;
    size_t covered = 0;
};

ShotLevels levels(const DeepBuffer& shot, const ImageF& image) {
    std::vector<double> lum;
    for (int y = 0; y < shot.height; ++y)
        for (int x = 0; x < shot.width; ++x) {
            const float a = shot.coverage(x, y);
            if (a < 0.5f) continue;
            const float* c = &image.rgba[(size_t(y) * size_t(shot.width) + size_t(x)) * 4];
            lum.push_back((0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]) / a);
        }
    ShotLevels s;
    s.covered = lum.size();
    if (lum.empty()) return s;
    std::sort(lum.begin(), lum.end());
    s.p50 = lum[lum.size() / 2];
    s.blackFraction = double(std::count_if(lum.begin(), lum.end(), [](double v) { return v < 0.0018; })) / double(lum.size());
    return s;
}

} // namespace

TEST(DefaultRig, EveryAssetSceneWithoutACameraShowsAtMidGrey) {
    const std::vector<std::string> scenes = {
        "Box.glb",          "Cameras.glb",  "CesiumMilkTruck.glb",          "CornellBox-Original.glb",
        "CornellBox-Suzanne.glb", "Duck.glb", "FlightHelmet-notex.glb", "MetalRoughSpheresNoTextures.glb",
        "Suzanne.glb",      "VulkanSamples-SubpassScene.glb", "WaterBottle.glb", "stanford-bunny-lowres.glb",
        "stanford-bunny.glb", "stanford-dragon-48k.glb", "utah-teapot.glb"};
    std::printf("%-34s %8s %9s %8s %8s\n", "scene", "factor", "p50", "black", "covered");
    for (const std::string& name : scenes) {
        SCOPED_TRACE(name);
        auto scene = loadScene(std::string(DFB_ASSETS_DIR "/") + name);
        ASSERT_TRUE(scene.ok()) << scene.error().toString();
        ASSERT_TRUE(scene->lights.empty()) << "the test set's scenes bring no lights";
        scene->cameras.clear(); // baked without a camera: auto framing
        BakeOptions o;
        o.width = 160;
        o.height = 90;
        o.envRays = 128;
        auto shot = bake(scene.value(), o);
        ASSERT_TRUE(shot.ok()) << shot.error().toString();
        const ShadowGeometry casters = shadowCasters(scene.value());
        bool imported = true;
        std::vector<std::string> warnings;
        Calibration calibration;
        auto rig = sessionRig(scene.value(), shot.value(), casters, &imported, &warnings, &calibration);
        ASSERT_TRUE(rig.ok()) << rig.error().toString();
        EXPECT_FALSE(imported);
        EXPECT_TRUE(warnings.empty()) << warnings.front();
        ASSERT_EQ(rig->lights.size(), 4u);
        const Light* key = rig->find("key");
        const Light* fill = rig->find("fill");
        const Light* rim = rig->find("rim");
        const Light* dome = rig->find("dome");
        ASSERT_TRUE(key && fill && rim && dome);
        EXPECT_EQ(dome->type, LightType::Environment);
        EXPECT_GT(calibration.factor, 0.f);

        // The layout against the camera: key and fill between the camera and the subject, the
        // rim beyond it; each spot aimed at the subject (its axis through the bounds).
        const glm::vec3 centre = scene->bounds.center();
        const glm::vec3 toCamera = shot->camera.position() - centre;
        auto at = [](const Light& l) { return glm::vec3(l.position[0], l.position[1], l.position[2]); };
        EXPECT_GT(glm::dot(at(*key) - centre, toCamera), 0.f);
        EXPECT_GT(glm::dot(at(*fill) - centre, toCamera), 0.f);
        EXPECT_LT(glm::dot(at(*rim) - centre, toCamera), 0.f);
        for (const Light* l : {key, fill, rim}) {
            const glm::vec3 axis(l->direction[0], l->direction[1], l->direction[2]);
            const glm::vec3 p = at(*l);
            const glm::vec3 closest = p + axis * glm::dot(centre - p, axis);
            EXPECT_LT(glm::length(closest - centre), scene->bounds.radius()) << l->name << " aims past the subject";
            EXPECT_GT(glm::dot(axis, centre - p), 0.f) << l->name << " faces away";
        }

        // Rendered by an engine of its own (nothing from the calibration's).
        auto engine = Engine::create(shot.value(), casters);
        ASSERT_TRUE(engine.ok()) << engine.error().toString();
        auto image = engine.value()->renderLinear(rig.value());
        ASSERT_TRUE(image.ok()) << image.error().toString();
        const ShotLevels s = levels(shot.value(), image.value());
        std::printf("%-34s %8.3g %9.4f %7.2f%% %8zu\n", name.c_str(), double(calibration.factor), s.p50, 100 * s.blackFraction,
                    s.covered);
        ASSERT_GT(s.covered, 100u) << "auto framing sees the subject";
        EXPECT_GE(s.p50, 0.09);
        EXPECT_LE(s.p50, 0.36);
        // Black: in the key's shadow, facing away from the fill and hidden from most of the dome.
        // The most is VulkanSamples-SubpassScene's: 4.7 % at 160 x 90 and 4.6 % at 320 x 180
        // (measured 2026-12-06), three fifths of it a black-albedo material in the vaults, lit by
        // the dome's reflection alone. With the dome at a fifth of the key it was 6.4 % (the
        // issue's limit is 5 %; docs/lighting.md, "Default rig").
        EXPECT_LE(s.blackFraction, 0.05);
    }
}

// The plain bounds rig (defaultRig: key and fill, no dome) is what the test set showed before:
// metal stays black. MetalRoughSpheresNoTextures has a row of fully metallic spheres; without
// an environment the share of black covered pixels is far above the default rig's 5 %.
TEST(DefaultRig, WithoutTheDomeMetalIsBlack) {
    auto scene = loadScene(DFB_ASSETS_DIR "/MetalRoughSpheresNoTextures.glb");
    ASSERT_TRUE(scene.ok()) << scene.error().toString();
    scene->cameras.clear();
    BakeOptions o;
    o.width = 160;
    o.height = 90;
    o.envRays = 32;
    auto shot = bake(scene.value(), o);
    ASSERT_TRUE(shot.ok()) << shot.error().toString();
    const ShadowGeometry casters = shadowCasters(scene.value());
    auto engine = Engine::create(shot.value(), casters);
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    const Bounds& b = scene->bounds;
    Rig plain = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    auto calibrated = calibrateRig(*engine.value(), shot.value(), plain);
    Rig rig = threePointRig(scene->bounds, shot->camera);
    auto withDome = calibrateRig(*engine.value(), shot.value(), rig);
    ASSERT_TRUE(withDome.ok()) << withDome.error().toString();
    auto image = engine.value()->renderLinear(rig);
    ASSERT_TRUE(image.ok());
    const ShotLevels s = levels(shot.value(), image.value());
    if (calibrated.ok()) {
        auto plainImage = engine.value()->renderLinear(plain);
        ASSERT_TRUE(plainImage.ok());
        const ShotLevels p = levels(shot.value(), plainImage.value());
        std::printf("key + fill: black %.1f %%; three-point + dome: black %.1f %%\n", 100 * p.blackFraction, 100 * s.blackFraction);
        EXPECT_GT(p.blackFraction, 4 * s.blackFraction + 0.05);
    } else {
        std::printf("key + fill: %s\n", calibrated.error().toString().c_str()); // median black: nothing to scale
    }
    EXPECT_LE(s.blackFraction, 0.05);
}
