// Every real scene of tests/assets bakes (at a modest size), and what it stores is right:
// positions reproject to their pixels, normals are unit and face the camera, ids point into the
// manifest. Also: scenes with several cameras, orthographic cameras, scenes without a camera
// (automatic framing and --look-from/--look-at).

#include "support/Assets.h"

#include <dfb/gbuffer/Baker.h>

#include <gtest/gtest.h>

#include <filesystem>

using namespace dfb;

namespace {

struct Checked {
    size_t covered = 0;
    double worstReprojectionPx = 0;
    double worstNormalLengthError = 0;
    double worstFacing = 1; // min over samples of dot(N, V)
};

Checked check(const DeepBuffer& b) {
    Checked c;
    const glm::vec3 eye = b.camera.position(), fwd = b.camera.forward();
    for (int y = 0; y < b.height; ++y)
        for (int x = 0; x < b.width; ++x) {
            for (uint32_t s = b.firstSample(x, y); s < b.firstSample(x, y) + b.pixelSamples(x, y); ++s) {
                if (b.A[s] <= 0.f) {
                    EXPECT_EQ(b.objectId[s], 0u);
                    continue;
                }
                ++c.covered;
                const glm::vec4 clip = b.camera.worldToNDC * glm::vec4(b.position(s), 1.f);
                const double px = (clip.x / clip.w + 1.0) * 0.5 * b.width - 0.5;
                const double py = (1.0 - clip.y / clip.w) * 0.5 * b.height - 0.5;
                c.worstReprojectionPx = std::max({c.worstReprojectionPx, std::abs(px - x), std::abs(py - y)});
                const glm::vec3 n = b.normal(s);
                c.worstNormalLengthError = std::max(c.worstNormalLengthError, double(std::abs(glm::length(n) - 1.f)));
                const glm::vec3 v = b.camera.orthographic ? -fwd : glm::normalize(eye - b.position(s));
                c.worstFacing = std::min(c.worstFacing, double(glm::dot(n, v)));
                EXPECT_GE(b.objectId[s], 1u);
                EXPECT_LE(b.objectId[s], b.objectNames.size());
                EXPECT_GE(b.materialId[s], 1u);
                EXPECT_LE(b.materialId[s], b.materialNames.size());
            }
        }
    return c;
}

Result<DeepBuffer> bakeAsset(const std::string& file, BakeOptions o) {
    auto scene = loadScene(test::assetPath(file));
    if (!scene) return scene.error();
    return bake(scene.value(), o);
}

void expectGood(const std::string& what, const DeepBuffer& b) {
    const Checked c = check(b);
    std::printf("%-40s covered %6zu, reprojection <= %.3f px, |N|-1 <= %.4f, min N.V %.4f\n", what.c_str(), c.covered,
                c.worstReprojectionPx, c.worstNormalLengthError, c.worstFacing);
    EXPECT_GT(c.covered, b.pixelCount() / 50) << what << ": the scene is barely in view";
    // Half a pixel, plus the jitter of multi-sample bakes (merged samples lie inside the pixel).
    EXPECT_LT(c.worstReprojectionPx, 0.5 + 1e-3) << what;
    EXPECT_LT(c.worstNormalLengthError, 2e-3) << what; // half precision
    EXPECT_GT(c.worstFacing, -2e-3) << what;           // normals face the camera (half precision)
}

class EveryAsset : public ::testing::TestWithParam<std::string> {};

} // namespace

TEST_P(EveryAsset, BakesWithValidValues) {
    DFB_REQUIRE_ASSETS();
    BakeOptions o;
    o.width = 96;
    o.height = 64;
    auto b = bakeAsset(GetParam(), o);
    ASSERT_TRUE(b.ok()) << b.error().toString();
    expectGood(GetParam(), b.value());
    EXPECT_EQ(b->sourceSha256.size(), 64u);
}

INSTANTIATE_TEST_SUITE_P(
    Assets, EveryAsset,
    ::testing::Values("Box.glb", "Cameras.glb", "CesiumMilkTruck.glb", "CornellBox-Original.glb",
                      "CornellBox-Suzanne.glb", "Duck.glb", "FlightHelmet-notex.glb",
                      "MetalRoughSpheresNoTextures.glb", "Suzanne.glb", "VulkanSamples-SubpassScene.glb",
                      "WaterBottle.glb", "stanford-bunny-lowres.glb", "stanford-bunny.glb", "stanford-dragon-48k.glb",
                      "utah-teapot.glb"),
    [](const ::testing::TestParamInfo<std::string>& param) {
        std::string n = param.param.substr(0, param.param.size() - 4);
        for (char& ch : n)
            if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
        return n;
    });

TEST(AssetCameras, EveryCameraOfAFileCanBeChosenByName) {
    DFB_REQUIRE_ASSETS();
    for (const char* file : {"Cameras.glb"}) {
        auto scene = loadScene(test::assetPath(file));
        ASSERT_TRUE(scene.ok()) << scene.error().toString();
        ASSERT_GE(scene->cameras.size(), 2u) << file;
        size_t baked = 0;
        bool sawOrtho = false;
        for (const SceneCamera& cam : scene->cameras) {
            BakeOptions o;
            o.width = 64;
            o.height = 48;
            o.cameraName = cam.name;
            auto b = bake(scene.value(), o);
            ASSERT_TRUE(b.ok()) << file << " camera " << cam.name << ": " << b.error().toString();
            EXPECT_EQ(b->camera.name, cam.name);
            EXPECT_EQ(b->camera.orthographic, cam.orthographic);
            sawOrtho |= cam.orthographic;
            const Checked c = check(b.value());
            EXPECT_LT(c.worstReprojectionPx, 0.501) << file << " " << cam.name;
            ++baked;
        }
        if (std::string(file) == "Cameras.glb") {
            EXPECT_TRUE(sawOrtho) << "Cameras.glb has an orthographic camera";
        }
    }
}

TEST(AssetCameras, SceneWithoutCameraTakesLookFromAndAutomaticFraming) {
    DFB_REQUIRE_ASSETS();
    BakeOptions o;
    o.width = 96;
    o.height = 64;
    auto autoFramed = bakeAsset("VulkanSamples-SubpassScene.glb", o);
    ASSERT_TRUE(autoFramed.ok()) << autoFramed.error().toString();
    EXPECT_EQ(autoFramed->camera.name, "auto");
    expectGood("SubpassScene auto-framed", autoFramed.value());
    o.lookFrom = glm::vec3(14.f, 8.f, 14.f);
    o.lookAt = glm::vec3(0.f, 2.f, 0.f);
    o.fovDegrees = 50.f;
    auto looked = bakeAsset("VulkanSamples-SubpassScene.glb", o);
    ASSERT_TRUE(looked.ok()) << looked.error().toString();
    EXPECT_EQ(looked->camera.name, "lookat");
    EXPECT_NEAR(glm::degrees(looked->camera.yfovRadians), 50.f, 1e-3f);
    EXPECT_NEAR(glm::length(looked->camera.position() - *o.lookFrom), 0.f, 1e-3f);
    expectGood("SubpassScene --look-from", looked.value());
}

TEST(AssetCameras, MultiSampleBakeOfATexturedAssetIsDeep) {
    DFB_REQUIRE_ASSETS();
    BakeOptions o;
    o.width = 96;
    o.height = 64;
    o.samples = 4;
    auto b = bakeAsset("CesiumMilkTruck.glb", o);
    ASSERT_TRUE(b.ok()) << b.error().toString();
    EXPECT_FALSE(b->isFlat());
    EXPECT_EQ(b->samplesPerPixel, 4);
    expectGood("CesiumMilkTruck 4 spp", b.value());
    // Coverages of a pixel add up to at most 1, and interior pixels are fully covered.
    size_t full = 0;
    for (int y = 0; y < b->height; ++y)
        for (int x = 0; x < b->width; ++x) {
            EXPECT_LE(b->coverage(x, y), 1.f + 1e-3f);
            full += b->coverage(x, y) > 0.999f;
        }
    EXPECT_GT(full, 100u);
}
