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

// Automatic framing (issue 20 point 5) fits the geometry, not its bounding sphere: every asset
// scene without a camera covers at least 40 % of the image's width or height (the sphere fit
// left an object at 11-13 % of the pixels), is centred, and is not cut by the image's edges
// (the 5 % margin leaves at least one empty column and row on every side at this size).
TEST(BakeCamera, AutomaticFramingFitsTheGeometryWithASmallMargin) {
    DFB_REQUIRE_ASSETS();
    int scenes = 0;
    for (const auto& entry : std::filesystem::directory_iterator(DFB_ASSETS_DIR)) {
        if (entry.path().extension() != ".glb") continue;
        auto scene = loadScene(entry.path().string());
        ASSERT_TRUE(scene.ok()) << scene.error().toString();
        if (!scene->cameras.empty()) continue;
        ++scenes;
        BakeOptions o;
        o.width = 96;
        o.height = 54;
        o.envRays = 0;
        auto b = bake(scene.value(), o);
        ASSERT_TRUE(b.ok()) << entry.path() << ": " << b.error().toString();
        EXPECT_EQ(b->camera.name, "auto");
        int x0 = o.width, x1 = -1, y0 = o.height, y1 = -1;
        for (int y = 0; y < b->height; ++y)
            for (int x = 0; x < b->width; ++x) {
                if (b->coverage(x, y) <= 0.f) continue;
                x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
            }
        ASSERT_GE(x1, 0) << entry.path() << ": nothing in view";
        const double w = double(x1 - x0 + 1) / o.width, h = double(y1 - y0 + 1) / o.height;
        std::printf("%-36s covers %3.0f %% of the width, %3.0f %% of the height (columns %d..%d, rows %d..%d)\n",
                    entry.path().filename().c_str(), 100 * w, 100 * h, x0, x1, y0, y1);
        EXPECT_GE(std::max(w, h), 0.40) << entry.path();
        EXPECT_GT(std::max(w, h), 0.85) << entry.path() << ": the limiting axis is filled up to the margin";
        EXPECT_GE(x0, 1) << entry.path();
        EXPECT_GE(y0, 1) << entry.path();
        EXPECT_LE(x1, o.width - 2) << entry.path();
        EXPECT_LE(y1, o.height - 2) << entry.path();
        // Centred: the empty margins on either side differ by at most a few pixels.
        EXPECT_LE(std::abs(x0 - (o.width - 1 - x1)), 3) << entry.path();
        EXPECT_LE(std::abs(y0 - (o.height - 1 - y1)), 3) << entry.path();
    }
    EXPECT_GE(scenes, 5) << "asset scenes without a camera";
}
