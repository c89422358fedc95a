// glTF loading: real asset scenes load with the right triangle counts; bad files say what is wrong.

#include <dfb/gbuffer/Scene.h>
#include <dfb/server/AreaPattern.h>
#include <dfb/server/InitialRig.h>

#include <glm/gtc/quaternion.hpp>

#include "support/Assets.h"
#include "support/GltfBuilder.h"

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
    // Counts from tests/assets/README.md (mesh nodes x mesh triangles).
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

TEST(Scene, KhrLightsPunctualArePlacedByTheirNodes) {
    test::GltfBuilder b;
    tinygltf::Material m;
    m.name = "grey";
    b.addQuad("floor", -1, -1, 1, 1, 0, b.addMaterial(m));
    tinygltf::Light spot;
    spot.name = "key";
    spot.type = "spot";
    spot.intensity = 120;
    spot.color = {1.0, 0.5, 0.25};
    spot.spot.innerConeAngle = 0.3;
    spot.spot.outerConeAngle = 0.5;
    b.model.lights.push_back(spot);
    tinygltf::Light sun;
    sun.type = "directional";
    sun.intensity = 3;
    b.model.lights.push_back(sun);
    tinygltf::Light bulb;
    bulb.name = "desk lamp";
    bulb.type = "point";
    bulb.intensity = 7;
    b.model.lights.push_back(bulb);
    b.model.extensionsUsed.push_back("KHR_lights_punctual");
    for (int i = 0; i < 3; ++i) {
        tinygltf::Node n;
        n.name = i == 0 ? "key_node" : i == 1 ? "sun_node" : "bulb_node";
        n.translation = {1.0, 4.0, 2.0};
        // Rotate -90 degrees about X: the light's -Z points down (-Y).
        n.rotation = {-0.7071067811865476, 0, 0, 0.7071067811865476};
        tinygltf::Value::Object ext{{"light", tinygltf::Value(i)}};
        n.extensions["KHR_lights_punctual"] = tinygltf::Value(ext);
        b.model.nodes.push_back(n);
        b.model.scenes[0].nodes.push_back(int(b.model.nodes.size()) - 1);
    }
    const std::string path = (std::filesystem::temp_directory_path() / "dfb_lights.glb").string();
    ASSERT_TRUE(b.write(path));
    auto s = loadScene(path);
    ASSERT_TRUE(s.ok()) << s.error().toString();
    ASSERT_EQ(s->lights.size(), 3u);
    const SceneLight& k = s->lights[0];
    EXPECT_EQ(k.name, "key");
    EXPECT_EQ(k.type, "spot");
    EXPECT_NEAR(k.position.y, 4.f, 1e-5f);
    EXPECT_NEAR(k.direction.y, -1.f, 1e-5f);
    EXPECT_NEAR(k.outerConeRadians, 0.5f, 1e-6f);
    EXPECT_NEAR(k.intensity, 120.f, 1e-4f);
    EXPECT_NEAR(k.color.g, 0.5f, 1e-6f);
    EXPECT_EQ(s->lights[1].type, "directional");
    EXPECT_EQ(s->lights[2].type, "point");
    // They become the session's initial rig (spot, directional and point lights), names made valid.
    bool imported = false;
    const Rig rig = initialRig(s.value(), &imported);
    EXPECT_TRUE(imported);
    ASSERT_EQ(rig.lights.size(), 3u);
    EXPECT_EQ(rig.lights[0].type, LightType::Spot);
    EXPECT_NEAR(rig.lights[0].coneAngleDeg, 28.6479f, 1e-3f);
    EXPECT_NEAR(rig.lights[0].penumbraDeg, 11.4592f, 1e-3f);
    EXPECT_EQ(rig.lights[1].type, LightType::Directional);
    EXPECT_EQ(rig.lights[2].type, LightType::Point);
    EXPECT_EQ(rig.lights[2].name, "desk_lamp");
    EXPECT_FLOAT_EQ(rig.lights[2].intensityCd, 7.f);
    // A scene without lights gets the default key and fill.
    auto plain = loadScene(DFB_SOURCE_DIR "/scenes/tabletop.glb");
    ASSERT_TRUE(plain.ok());
    const Rig fallback = initialRig(plain.value(), &imported);
    EXPECT_FALSE(imported);
    EXPECT_EQ(fallback.lights.size(), 2u);
    std::filesystem::remove(path);
}

// Area lights travel in glTF as a node's extras.dfb_area_light (docs/gbuffer-format.md): placed
// and turned by the node, its -Z the emitting side and +X the emitter's width; bad fields are
// errors naming the node and the field.
TEST(Scene, AreaLightsAreReadFromNodeExtras) {
    auto write = [](const tinygltf::Value& area, const std::string& path) {
        test::GltfBuilder b;
        tinygltf::Material m;
        b.addQuad("floor", -1, -1, 1, 1, 0, b.addMaterial(m));
        tinygltf::Node n;
        n.name = "softbox";
        n.translation = {0.0, 3.0, 0.0};
        // -90 degrees about X (the node's -Z points down), then 30 degrees about the world's Y.
        const glm::quat q = glm::angleAxis(glm::radians(30.f), glm::vec3(0, 1, 0)) * glm::angleAxis(glm::radians(-90.f), glm::vec3(1, 0, 0));
        n.rotation = {q.x, q.y, q.z, q.w};
        n.extras = tinygltf::Value(tinygltf::Value::Object{{"dfb_area_light", area}});
        b.model.nodes.push_back(n);
        b.model.scenes[0].nodes.push_back(int(b.model.nodes.size()) - 1);
        return b.write(path);
    };
    using V = tinygltf::Value;
    const std::string path = (std::filesystem::temp_directory_path() / "dfb_area.glb").string();
    ASSERT_TRUE(write(V(V::Object{{"shape", V(std::string("rect"))}, {"size", V(V::Array{V(2.0), V(0.5)})}, {"intensity", V(40.0)},
                                  {"color", V(V::Array{V(1.0), V(0.9), V(0.8)})}, {"pattern", V(std::string("stripes.png"))},
                                  {"shadowGrid", V(V::Array{V(3), V(2)})}}),
                      path));
    auto s = loadScene(path);
    ASSERT_TRUE(s.ok()) << s.error().toString();
    ASSERT_EQ(s->lights.size(), 1u);
    const Rig rig = initialRig(s.value());
    ASSERT_EQ(rig.lights.size(), 1u);
    const Light& l = rig.lights[0];
    EXPECT_EQ(l.type, LightType::Area);
    EXPECT_EQ(l.name, "softbox");
    EXPECT_NEAR(l.position[1], 3.f, 1e-5f);
    EXPECT_NEAR(l.direction[1], -1.f, 1e-5f);
    EXPECT_FLOAT_EQ(l.areaSize[0], 2.f);
    EXPECT_FLOAT_EQ(l.areaSize[1], 0.5f);
    EXPECT_FLOAT_EQ(l.intensityCd, 40.f);
    EXPECT_EQ(l.pattern, "stripes.png");
    EXPECT_EQ(l.shadowGrid[0], 3);
    // The emitter's width axis is the node's +X: (cos 30, 0, -sin 30) after the turn about Y.
    const auto f = areaFrameOf<float>(l);
    EXPECT_NEAR(f.right.x, std::cos(glm::radians(30.f)), 1e-5f);
    EXPECT_NEAR(f.right.z, -std::sin(glm::radians(30.f)), 1e-5f);
    // Bad fields: errors naming the node and the field.
    for (const auto& [bad, words] : std::vector<std::pair<V, std::string>>{
             {V(V::Object{{"size", V(V::Array{V(0.0), V(1.0)})}}), "extras.dfb_area_light.size[0]"},
             {V(V::Object{{"shape", V(std::string("hexagon"))}}), "extras.dfb_area_light.shape"},
             {V(V::Object{{"shadowGrid", V(V::Array{V(40), V(1)})}}), "extras.dfb_area_light.shadowGrid"},
             {V(3.0), "must be an object"}}) {
        ASSERT_TRUE(write(bad, path));
        auto r = loadScene(path);
        ASSERT_FALSE(r.ok());
        EXPECT_NE(r.error().message.find("node 'softbox'"), std::string::npos) << r.error().message;
        EXPECT_NE(r.error().message.find(words), std::string::npos) << r.error().message;
    }
    std::filesystem::remove(path);
}
