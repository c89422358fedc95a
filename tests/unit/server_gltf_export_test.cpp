// glTF export of the rig (issue 19 point 7, issue 18 point 1; dfb/server/GltfExport.h,
// docs/gbuffer-format.md "Lights in glTF"): export -> loadScene -> initialRig gives the same rig
// JSON for every light type; the KHR_lights_punctual output follows the extension's schema; the
// punctual values alone (what other tools read) import to the same lights within float rounding;
// a re-export replaces the scene's lights instead of adding to them; bad input is refused.

#include "support/EveryLightRig.h"
#include "support/GltfBuilder.h"

#include <dfb/gbuffer/Scene.h>
#include <dfb/lightmath/Falloff.h>
#include <dfb/protocol/Codec.h>
#include <dfb/server/AreaPattern.h>
#include <dfb/server/GltfExport.h>
#include <dfb/server/InitialRig.h>

#include <gtest/gtest.h>

#include <tiny_gltf.h>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

using namespace dfb;
using json = nlohmann::json;

namespace {

const std::string TABLETOP = DFB_SOURCE_DIR "/scenes/tabletop.glb";

std::string tempPath(const std::string& name) { return (std::filesystem::temp_directory_path() / name).string(); }

void writeBytes(const std::string& path, const std::string& bytes) {
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), std::streamsize(bytes.size()));
}

// Exports `rig` into the tabletop scene, writes it to `path` and loads it back as a rig.
Rig roundTrip(const Rig& rig, const std::string& path, std::vector<std::string>* warnings = nullptr) {
    auto glb = exportGltf(TABLETOP, rig);
    EXPECT_TRUE(glb.ok()) << glb.error().toString();
    if (!glb) return {};
    writeBytes(path, glb.value());
    auto scene = loadScene(path);
    EXPECT_TRUE(scene.ok()) << scene.error().toString();
    if (!scene) return {};
    bool imported = false;
    Rig back = initialRig(scene.value(), &imported, warnings);
    EXPECT_TRUE(imported);
    return back;
}

} // namespace

TEST(GltfExport, ImportGivesTheSameRigForEveryLightType) {
    const Rig rig = test::everyLightRig(true);
    // The test's rig is a valid one (what a client could PUT).
    ASSERT_TRUE(protocol::rigFromJson(protocol::toJson(rig)).ok()) << protocol::rigFromJson(protocol::toJson(rig)).error().toString();
    const std::string path = tempPath("dfb_export_roundtrip.glb");
    std::vector<std::string> warnings;
    const Rig back = roundTrip(rig, path, &warnings);
    EXPECT_TRUE(warnings.empty()) << warnings[0];
    ASSERT_EQ(back.lights.size(), rig.lights.size());
    for (size_t i = 0; i < rig.lights.size(); ++i) {
        // Exact: the same JSON, every number bit for bit (keys, chains, corners, linking included).
        EXPECT_EQ(protocol::toJson(back.lights[i]), protocol::toJson(rig.lights[i])) << rig.lights[i].name;
    }
    EXPECT_EQ(back.exposureStops, rig.exposureStops);
    EXPECT_EQ(back.viewTransform, rig.viewTransform);
    EXPECT_EQ(back.time, rig.time);
    // The scene itself came through: meshes, the camera.
    auto source = loadScene(TABLETOP, {.loadImages = true});
    auto exported = loadScene(path, {.loadImages = true});
    ASSERT_TRUE(source.ok() && exported.ok());
    EXPECT_EQ(exported->triangleCount(), source->triangleCount());
    EXPECT_EQ(exported->objectNames, source->objectNames);
    EXPECT_EQ(exported->images.size(), source->images.size());
    ASSERT_EQ(exported->cameras.size(), source->cameras.size());
    for (size_t c = 0; c < source->cameras.size(); ++c) {
        EXPECT_EQ(exported->cameras[c].name, source->cameras[c].name);
        EXPECT_EQ(exported->cameras[c].worldToCamera, source->cameras[c].worldToCamera);
        EXPECT_EQ(exported->cameras[c].yfovRadians, source->cameras[c].yfovRadians);
    }
    std::filesystem::remove(path);
}

// The KHR_lights_punctual schema (github.com/KhronosGroup/glTF, extensions/2.0/Khronos/
// KHR_lights_punctual/schema/light.schema.json, light.spot.schema.json, and the README's
// "Light Types" and "Spot" sections), checked on the file's JSON as another reader sees it:
//   light: "type" required, one of "directional", "point", "spot"; "color" 3 numbers each in
//     [0, 1] (default [1, 1, 1]); "intensity" a number >= 0 (default 1); "range" a number > 0
//     when present (point and spot only: "must not be defined" for directional per the README's
//     range section); "spot" required when type is "spot" (and only then).
//   spot: "innerConeAngle" in [0, pi/2] (default 0), "outerConeAngle" in (0, pi/2] (default
//     pi/4); README: innerConeAngle "must be greater than or equal to 0 and less than
//     outerConeAngle", outerConeAngle "greater than innerConeAngle and less than or equal to PI / 2".
//   node: "extensions.KHR_lights_punctual.light" an index into the lights; the light points down
//     the node's local -Z and ignores scale (README "Adding Light Instances to Nodes"): we write no
//     scale or matrix, and a unit quaternion.
TEST(GltfExport, PunctualLightsFollowTheExtensionSchema) {
    const Rig rig = test::everyLightRig(true);
    const Rig now = protocol::evaluateRig(rig);
    auto glb = exportGltf(TABLETOP, rig);
    ASSERT_TRUE(glb.ok()) << glb.error().toString();
    const auto doc = test::glbJson(glb.value());
    ASSERT_TRUE(doc.has_value()) << "not a well-formed GLB";
    const json& j = *doc;
    ASSERT_TRUE(j["extensionsUsed"].is_array());
    EXPECT_NE(std::find(j["extensionsUsed"].begin(), j["extensionsUsed"].end(), "KHR_lights_punctual"), j["extensionsUsed"].end());
    if (j.contains("extensionsRequired")) {
        EXPECT_EQ(std::find(j["extensionsRequired"].begin(), j["extensionsRequired"].end(), "KHR_lights_punctual"),
                  j["extensionsRequired"].end());
    }
    const json& lights = j["extensions"]["KHR_lights_punctual"]["lights"];
    ASSERT_TRUE(lights.is_array());
    constexpr double HALF_PI = 1.5707963267948966;
    for (const json& l : lights) {
        ASSERT_TRUE(l.is_object());
        ASSERT_TRUE(l.contains("type") && l["type"].is_string());
        const std::string type = l["type"];
        EXPECT_TRUE(type == "directional" || type == "point" || type == "spot") << type;
        if (l.contains("color")) {
            ASSERT_TRUE(l["color"].is_array());
            ASSERT_EQ(l["color"].size(), 3u);
            for (const json& c : l["color"]) {
                ASSERT_TRUE(c.is_number());
                EXPECT_GE(double(c), 0.0);
                EXPECT_LE(double(c), 1.0);
            }
        }
        if (l.contains("intensity")) {
            ASSERT_TRUE(l["intensity"].is_number());
            EXPECT_GE(double(l["intensity"]), 0.0);
        }
        if (l.contains("range")) {
            EXPECT_NE(type, "directional");
            ASSERT_TRUE(l["range"].is_number());
            EXPECT_GT(double(l["range"]), 0.0);
        }
        EXPECT_EQ(l.contains("spot"), type == "spot");
        if (type == "spot") {
            const json& s = l["spot"];
            const double inner = s.value("innerConeAngle", 0.0), outer = s.value("outerConeAngle", 0.7853981633974483);
            EXPECT_GE(inner, 0.0);
            EXPECT_LT(inner, outer);
            EXPECT_LT(float(inner), float(outer)) << "a reader rounding to floats must still see inner < outer";
            EXPECT_GT(outer, 0.0);
            EXPECT_LE(outer, HALF_PI);
        }
        if (l.contains("name")) {
            EXPECT_TRUE(l["name"].is_string());
        }
    }
    // One node per rig light, named after it, at the root of the default scene; the enabled spot,
    // point, directional and BendyLight ones reference a punctual light.
    size_t punctual = 0;
    const json& roots = j["scenes"][j.value("scene", 0)]["nodes"];
    for (size_t i = 0; i < rig.lights.size(); ++i) {
        const Light& l = now.lights[i];
        const bool expectPunctual = l.enabled && (l.type == LightType::Spot || l.type == LightType::Point ||
                                                  l.type == LightType::Directional || l.type == LightType::Bendy);
        punctual += expectPunctual ? 1 : 0;
        const json* node = nullptr;
        int index = -1;
        for (size_t n = 0; n < j["nodes"].size(); ++n) {
            if (j["nodes"][n].value("name", "") == l.name) {
                node = &j["nodes"][n];
                index = int(n);
            }
        }
        ASSERT_NE(node, nullptr) << l.name;
        EXPECT_NE(std::find(roots.begin(), roots.end(), index), roots.end()) << l.name;
        EXPECT_FALSE(node->contains("matrix"));
        EXPECT_FALSE(node->contains("scale"));
        ASSERT_TRUE(node->contains("rotation") && node->contains("translation"));
        const json& r = (*node)["rotation"];
        const glm::dquat q(r[3].get<double>(), r[0].get<double>(), r[1].get<double>(), r[2].get<double>());
        EXPECT_NEAR(glm::length(q), 1.0, 1e-12);
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(double((*node)["translation"][size_t(k)]), double(l.position[size_t(k)]), 1e-6);
        // The node's -Z is where the light points (area lights: the emitting side).
        const glm::dvec3 minusZ = glm::mat3_cast(q) * glm::dvec3(0, 0, -1);
        const glm::dvec3 dir = glm::normalize(glm::dvec3(l.direction[0], l.direction[1], l.direction[2]));
        EXPECT_NEAR(glm::dot(minusZ, dir), 1.0, 1e-9) << l.name;
        // Every light carries its rig JSON; area lights the dfb_area_light convention as well.
        ASSERT_TRUE((*node)["extras"].contains("dfb_light")) << l.name;
        EXPECT_EQ((*node)["extras"]["dfb_light"], protocol::toJson(rig.lights[i])) << l.name;
        EXPECT_EQ((*node)["extras"].contains("dfb_area_light"), l.type == LightType::Area || l.type == LightType::BentArea);
        const bool hasPunctual = node->contains("extensions") && (*node)["extensions"].contains("KHR_lights_punctual");
        EXPECT_EQ(hasPunctual, expectPunctual) << l.name;
        if (!hasPunctual) continue;
        const json& ref = (*node)["extensions"]["KHR_lights_punctual"]["light"];
        ASSERT_TRUE(ref.is_number_integer());
        ASSERT_LT(size_t(ref), lights.size());
        const json& pl = lights[size_t(ref)];
        EXPECT_EQ(pl["name"], l.name);
        // Units: the rig's are the extension's; colour x intensity is the rig's.
        const double scale = std::max({1.0, double(l.color[0]), double(l.color[1]), double(l.color[2])});
        EXPECT_NEAR(double(pl["intensity"]), double(l.intensityCd) * scale, 1e-9 * scale * l.intensityCd);
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(double(pl["color"][size_t(c)]) * double(pl["intensity"]), double(l.color[size_t(c)]) * double(l.intensityCd), 1e-5);
        }
        if (l.type == LightType::Directional) {
            EXPECT_EQ(pl["type"], "directional");
        }
        if (l.type == LightType::Point) {
            EXPECT_EQ(pl["type"], "point");
        }
        if (l.type == LightType::Spot || l.type == LightType::Bendy) {
            EXPECT_EQ(pl["type"], "spot");
            EXPECT_NEAR(double(pl["spot"]["outerConeAngle"]), glm::radians(double(l.coneAngleDeg)), 1e-9);
            const double inner = glm::radians(double(l.coneAngleDeg) - double(l.penumbraDeg));
            EXPECT_NEAR(double(pl["spot"]["innerConeAngle"]), inner, l.penumbraDeg > 0 ? 1e-9 : 1e-5);
        }
    }
    EXPECT_EQ(lights.size(), punctual);
    // The intensity of the keyed spot is the rig's at its time (1.5 s between keys 20 and 60),
    // its colour (2, 1, 0.5) scaled to (1, 0.5, 0.25) and twice the intensity.
    const json& key = lights[0];
    EXPECT_EQ(key["name"], "key");
    EXPECT_NEAR(double(key["color"][0]), 1.0, 1e-9);
    EXPECT_NEAR(double(key["color"][2]), 0.25, 1e-9);
    EXPECT_NEAR(double(key["intensity"]), 2.0 * double(now.lights[0].intensityCd), 1e-4);
    EXPECT_GT(double(now.lights[0].intensityCd), 20.0);
    EXPECT_LT(double(now.lights[0].intensityCd), 60.0);
}

// What a reader that knows only KHR_lights_punctual and dfb_area_light gets: the import without
// extras.dfb_light gives the same placement, colour x intensity, cone and area shape (the
// conversions are the import's inverse), to float rounding.
TEST(GltfExport, PunctualValuesAloneImportToTheSameLights) {
    const Rig rig = protocol::evaluateRig(test::everyLightRig());
    auto glb = exportGltf(TABLETOP, rig);
    ASSERT_TRUE(glb.ok());
    const std::string path = tempPath("dfb_export_plain.glb");
    writeBytes(path, glb.value());
    tinygltf::Model model;
    tinygltf::TinyGLTF io;
    std::string err, warn;
    ASSERT_TRUE(io.LoadBinaryFromFile(&model, &err, &warn, path)) << err;
    for (tinygltf::Node& n : model.nodes) {
        if (!n.extras.IsObject()) continue;
        tinygltf::Value::Object o = n.extras.Get<tinygltf::Value::Object>();
        o.erase("dfb_light");
        n.extras = tinygltf::Value(o);
    }
    ASSERT_TRUE(io.WriteGltfSceneToFile(&model, path, true, true, false, true));
    auto scene = loadScene(path);
    ASSERT_TRUE(scene.ok()) << scene.error().toString();
    const Rig plain = initialRig(scene.value());
    size_t found = 0;
    for (const Light& want : rig.lights) {
        const Light* got = plain.find(want.name);
        const bool standIn = want.enabled && want.type != LightType::BentArea;
        ASSERT_EQ(got != nullptr, standIn || want.type == LightType::BentArea) << want.name;
        if (!got) continue;
        ++found;
        const LightType expected = want.type == LightType::Bendy ? LightType::Spot : want.type == LightType::BentArea ? LightType::Area : want.type;
        EXPECT_EQ(got->type, expected) << want.name;
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(got->position[size_t(k)], want.position[size_t(k)], 1e-5f) << want.name;
            EXPECT_NEAR(got->direction[size_t(k)], want.direction[size_t(k)], 1e-5f) << want.name;
            EXPECT_NEAR(got->color[size_t(k)] * got->intensityCd, want.color[size_t(k)] * want.intensityCd, 1e-4f * want.intensityCd)
                << want.name;
        }
        if (expected == LightType::Spot) {
            EXPECT_NEAR(got->coneAngleDeg, want.coneAngleDeg, 1e-4f) << want.name;
            EXPECT_NEAR(got->penumbraDeg, want.penumbraDeg, 1e-4f) << want.name;
        }
        if (expected == LightType::Area) {
            EXPECT_EQ(got->areaShape, want.areaShape);
            EXPECT_EQ(got->areaSize, want.areaSize);
            EXPECT_EQ(got->shadowGrid, want.shadowGrid);
            // The emitter's axes (the roll) come back from the node's +X.
            const auto fw = areaFrameOf<double>(want), fg = areaFrameOf<double>(*got);
            EXPECT_NEAR(glm::dot(fw.right, fg.right), 1.0, 1e-6) << want.name;
        }
    }
    EXPECT_GE(found, 8u);
    std::filesystem::remove(path);
}

// Exporting an exported file again (its lights now in the source scene) replaces them: each light
// once, and the nodes that were only lights are gone.
TEST(GltfExport, ReExportReplacesTheScenesLights) {
    const Rig rig = test::everyLightRig();
    auto first = exportGltf(TABLETOP, rig);
    ASSERT_TRUE(first.ok());
    const std::string path = tempPath("dfb_export_first.glb");
    writeBytes(path, first.value());
    Rig smaller = rig;
    smaller.lights.resize(3);
    auto second = exportGltf(path, smaller);
    ASSERT_TRUE(second.ok()) << second.error().toString();
    const auto a = test::glbJson(first.value()), b = test::glbJson(second.value());
    ASSERT_TRUE(a && b);
    EXPECT_EQ((*b)["nodes"].size(), (*a)["nodes"].size() - rig.lights.size() + smaller.lights.size());
    EXPECT_EQ((*b)["extensions"]["KHR_lights_punctual"]["lights"].size(), 3u);
    const std::string path2 = tempPath("dfb_export_second.glb");
    writeBytes(path2, second.value());
    auto scene = loadScene(path2);
    ASSERT_TRUE(scene.ok());
    const Rig back = initialRig(scene.value());
    ASSERT_EQ(back.lights.size(), 3u);
    for (size_t i = 0; i < 3; ++i) EXPECT_EQ(protocol::toJson(back.lights[i]), protocol::toJson(smaller.lights[i]));
    std::filesystem::remove(path);
    std::filesystem::remove(path2);
}

TEST(GltfExport, RefusesWhatItCannotExport) {
    // No lights: nothing is read or written.
    Rig empty;
    auto r = exportGltf(TABLETOP, empty);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::MissingData);
    EXPECT_NE(r.error().message.find("no lights"), std::string::npos);
    const Rig rig = test::everyLightRig();
    // A scene that is not there, and one that is not glTF: errors naming the file.
    auto missing = exportGltf(tempPath("dfb_no_such_scene.glb"), rig);
    ASSERT_FALSE(missing.ok());
    EXPECT_EQ(missing.error().code, ErrorCode::FileNotFound);
    EXPECT_NE(missing.error().message.find("dfb_no_such_scene.glb"), std::string::npos);
    const std::string junk = tempPath("dfb_export_junk.glb");
    writeBytes(junk, "glTF this is not a scene");
    auto bad = exportGltf(junk, rig);
    ASSERT_FALSE(bad.ok());
    EXPECT_EQ(bad.error().code, ErrorCode::InvalidFile);
    EXPECT_NE(bad.error().message.find("dfb_export_junk.glb"), std::string::npos);
    std::filesystem::remove(junk);
}

// A dfb_light the rig's codec refuses (a file edited by hand) is reported, naming the node, and
// the light is read from its stand-in.
TEST(GltfExport, ARefusedRigJsonFallsBackToTheStandIn) {
    Rig rig;
    rig.lights = {test::everyLightRig().lights[0]};
    auto glb = exportGltf(TABLETOP, rig);
    ASSERT_TRUE(glb.ok());
    const std::string path = tempPath("dfb_export_badjson.glb");
    writeBytes(path, glb.value());
    tinygltf::Model model;
    tinygltf::TinyGLTF io;
    std::string err, warn;
    ASSERT_TRUE(io.LoadBinaryFromFile(&model, &err, &warn, path)) << err;
    bool edited = false;
    for (tinygltf::Node& n : model.nodes) {
        if (!n.extras.Has("dfb_light")) continue;
        tinygltf::Value::Object o = n.extras.Get<tinygltf::Value::Object>();
        tinygltf::Value::Object l = o["dfb_light"].Get<tinygltf::Value::Object>();
        l["coneAngle"] = tinygltf::Value(400.0);
        o["dfb_light"] = tinygltf::Value(l);
        n.extras = tinygltf::Value(o);
        edited = true;
    }
    ASSERT_TRUE(edited);
    ASSERT_TRUE(io.WriteGltfSceneToFile(&model, path, true, true, false, true));
    auto scene = loadScene(path);
    ASSERT_TRUE(scene.ok()) << scene.error().toString();
    std::vector<std::string> warnings;
    const Rig back = initialRig(scene.value(), nullptr, &warnings);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("node 'key'"), std::string::npos) << warnings[0];
    EXPECT_NE(warnings[0].find("coneAngle"), std::string::npos) << warnings[0];
    ASSERT_EQ(back.lights.size(), 1u);
    EXPECT_EQ(back.lights[0].type, LightType::Spot);
    EXPECT_NEAR(back.lights[0].coneAngleDeg, 30.f, 1e-4f);
    std::filesystem::remove(path);
}

// A .gltf with an external buffer and an external image becomes one self-contained GLB: one
// buffer (the binary chunk, no URI), the image in a buffer view of it with its mime type, and
// the same decoded texture when loaded.
TEST(GltfExport, ExternalBuffersAndImagesArePackedIntoTheGlb) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "dfb_export_gltf";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    test::GltfBuilder b;
    tinygltf::Material m;
    m.pbrMetallicRoughness.baseColorTexture.index = b.addTexture(2, 2, {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 255});
    b.addQuad("floor", -1, -1, 1, 1, 0, b.addMaterial(m));
    ASSERT_TRUE(b.write((dir / "first.glb").string())); // fills the builder's buffer
    tinygltf::TinyGLTF w;
    ASSERT_TRUE(w.WriteGltfSceneToFile(&b.model, (dir / "scene.gltf").string(), false, false, true, false));
    ASSERT_TRUE(std::filesystem::exists(dir / "scene.bin"));
    // tinygltf names the image 0.png in scene.gltf but leaves writing it to us: the PNG bytes the
    // builder embedded in first.glb (a data URI), as tinygltf hands them to its image loader.
    {
        tinygltf::Model glbModel;
        tinygltf::TinyGLTF r;
        std::string png, err, warn;
        r.SetImageLoader(
            [](tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char* bytes, int size, void* user) {
                static_cast<std::string*>(user)->assign(reinterpret_cast<const char*>(bytes), size_t(size));
                return true;
            },
            &png);
        ASSERT_TRUE(r.LoadBinaryFromFile(&glbModel, &err, &warn, (dir / "first.glb").string())) << err;
        ASSERT_EQ(png.compare(1, 3, "PNG"), 0);
        writeBytes((dir / "0.png").string(), png);
    }
    Rig rig;
    rig.lights = {test::everyLightRig().lights[0]};
    auto glb = exportGltf((dir / "scene.gltf").string(), rig);
    ASSERT_TRUE(glb.ok()) << glb.error().toString();
    const auto j = test::glbJson(glb.value());
    ASSERT_TRUE(j.has_value());
    ASSERT_EQ((*j)["buffers"].size(), 1u);
    EXPECT_FALSE((*j)["buffers"][0].contains("uri"));
    ASSERT_EQ((*j)["images"].size(), 1u);
    EXPECT_FALSE((*j)["images"][0].contains("uri"));
    EXPECT_TRUE((*j)["images"][0].contains("bufferView"));
    EXPECT_EQ((*j)["images"][0].value("mimeType", ""), "image/png");
    const std::string out = (dir / "exported.glb").string();
    writeBytes(out, glb.value());
    std::filesystem::remove(dir / "scene.bin"); // nothing outside the GLB is needed
    std::filesystem::remove(dir / "0.png");
    auto scene = loadScene(out);
    ASSERT_TRUE(scene.ok()) << scene.error().toString();
    ASSERT_EQ(scene->images.size(), 1u);
    EXPECT_EQ(scene->images[0].width, 2);
    EXPECT_EQ(scene->images[0].rgba[4], 0);
    EXPECT_EQ(scene->images[0].rgba[5], 255);
    EXPECT_EQ(scene->lights.size(), 1u);
    std::filesystem::remove_all(dir);
}

// Scene lights with the same name (many exporters call them all "Light") get distinct names that
// stay valid rig names (at most 64 characters) however many there are.
TEST(GltfImport, ClashingLightNamesStayValid) {
    Scene scene;
    for (int i = 0; i < 120; ++i) {
        SceneLight sl;
        sl.name = std::string(70, 'L'); // longer than a rig name may be, too
        sl.type = "point";
        sl.position = glm::vec3(float(i), 1.f, 0.f);
        scene.lights.push_back(sl);
    }
    const Rig rig = initialRig(scene);
    ASSERT_EQ(rig.lights.size(), 120u);
    std::set<std::string> names;
    for (const Light& l : rig.lights) {
        EXPECT_LE(l.name.size(), 64u) << l.name;
        names.insert(l.name);
    }
    EXPECT_EQ(names.size(), 120u);
    auto back = protocol::rigFromJson(protocol::toJson(rig));
    EXPECT_TRUE(back.ok()) << back.error().toString();
}
