// glTF loading: real asset scenes load with the right triangle counts; bad files say what is wrong.

#include <dfb/gbuffer/Scene.h>

#include "support/Assets.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

using namespace dfb;

TEST(Scene, LoadsBundledTabletop) {
    auto s = loadScene(DFB_SOURCE_DIR "/scenes/tabletop.glb");
    ASSERT_TRUE(s.ok()) << s.error().toString();
    EXPECT_GT(s->triangleCount(), 100000u); // the full Stanford bunny is 69,666 triangles
    EXPECT_EQ(s->objectNames.size(), 5u);
    ASSERT_EQ(s->cameras.size(), 1u);
    EXPECT_EQ(s->cameras[0].name, "shot_cam");
    EXPECT_NEAR(s->bounds.min.y, 0.f, 1e-4f); // everything stands on the table
}

TEST(Scene, InstancedAssetTriangleCountsMatchTheAssetsReadme) {
    DFB_REQUIRE_ASSETS();
    // Counts from ../shared/assets/README.md (mesh nodes x mesh triangles).
    struct Case { const char* file; size_t triangles; };
    for (const Case& c : {Case{"CesiumMilkTruck.glb", 3624}, Case{"Box.glb", 12}, Case{"CornellBox-Original.glb", 36},
                          Case{"VulkanSamples-SubpassScene.glb", 23388}}) {
        auto s = loadScene(test::assetPath(c.file));
        ASSERT_TRUE(s.ok()) << s.error().toString();
        EXPECT_EQ(s->triangleCount(), c.triangles) << c.file;
    }
}

TEST(Scene, CamerasAreFound) {
    DFB_REQUIRE_ASSETS();
    auto s = loadScene(test::assetPath("CornellBox-Original.glb"));
    ASSERT_TRUE(s.ok());
    ASSERT_EQ(s->cameras.size(), 1u);
    EXPECT_EQ(s->cameras[0].name, "CornellCamera");
    const glm::vec3 eye = glm::vec3(glm::inverse(s->cameras[0].worldToCamera)[3]);
    EXPECT_NEAR(eye.z, 3.87f, 1e-3f);
}

TEST(Scene, MissingFileAndGarbageGiveClearErrors) {
    auto a = loadScene("/no/such/scene.glb");
    ASSERT_FALSE(a.ok());
    EXPECT_EQ(a.error().code, ErrorCode::FileNotFound);

    const std::string path = (std::filesystem::temp_directory_path() / "dfb_garbage.glb").string();
    std::ofstream(path) << "\x01\x02garbage";
    auto b = loadScene(path);
    ASSERT_FALSE(b.ok());
    EXPECT_EQ(b.error().code, ErrorCode::InvalidFile);
    EXPECT_NE(b.error().message.find("not a glTF"), std::string::npos) << b.error().message;

    std::ofstream(path, std::ios::trunc) << "{\"asset\": {\"version\": \"2.0\"}, \"extensionsRequired\": [\"KHR_draco_mesh_compression\"], "
                                            "\"extensionsUsed\": [\"KHR_draco_mesh_compression\"]}";
    auto c = loadScene(path);
    ASSERT_FALSE(c.ok());
    EXPECT_NE(c.error().message.find("KHR_draco_mesh_compression"), std::string::npos) << c.error().message;
    std::filesystem::remove(path);
}
