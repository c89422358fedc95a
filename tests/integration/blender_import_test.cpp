// Blender reads the exported rig (issue 19 point 7): exportGltf writes every rig light of the test
// rig into the tabletop scene; Debian's Blender, headless, imports the file with its stock glTF
// importer (server/blender/dfb_inspect_gltf.py) and reports the lights it made. Every light that
// KHR_lights_punctual can express (spot, point, directional, and a BendyLight's unbent spot)
// arrives with its type, place, direction, colour, cone and the energy of the importer's
// documented conversion (io_scene_gltf2/blender/imp/gltf2_blender_light.py, lighting mode
// "Standard": W = cd * 4 pi / 683 for spot and point lights, W/m^2 = lx / 683 for suns;
// spot_size = 2 outerConeAngle, spot_blend = 1 - innerConeAngle / outerConeAngle); the lights the
// extension cannot carry (area, bent area, environment, disabled) make none.

#include "support/EveryLightRig.h"

#include <dfb/protocol/Codec.h>
#include <dfb/server/GltfExport.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>

using namespace dfb;
using json = nlohmann::json;

namespace {

constexpr double PI = 3.14159265358979323846;
constexpr double PBR_WATTS_TO_LUMENS = 683.0; // io_scene_gltf2/blender/com/gltf2_blender_conversion.py

double distance(const json& a, const Vec3& b) {
    double s = 0;
    for (size_t k = 0; k < 3; ++k) s += (double(a.at(k)) - double(b[k])) * (double(a.at(k)) - double(b[k]));
    return std::sqrt(s);
}

} // namespace

TEST(BlenderImport, ReadsEveryPunctualLightOfTheExportedRig) {
    const Rig rig = test::everyLightRig(true);
    const Rig now = protocol::evaluateRig(rig);
    auto glb = exportGltf(DFB_SOURCE_DIR "/scenes/tabletop.glb", rig);
    ASSERT_TRUE(glb.ok()) << glb.error().toString();
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "dfb_blender_import_test";
    std::filesystem::create_directories(dir);
    const std::string file = (dir / "rig.glb").string(), report = (dir / "report.json").string(), log = (dir / "blender.log").string();
    std::filesystem::remove(report);
    {
        std::ofstream out(file, std::ios::binary);
        out.write(glb->data(), std::streamsize(glb->size()));
    }
    const std::string command = "blender -b --factory-startup --python '" DFB_SOURCE_DIR "/server/blender/dfb_inspect_gltf.py' -- '" +
                                file + "' '" + report + "' > '" + log + "' 2>&1";
    ASSERT_EQ(std::system(command.c_str()), 0) << command << " failed; see " << log;
    std::ifstream in(report);
    ASSERT_TRUE(in.good()) << "Blender wrote no " << report << "; see " << log;
    const json j = json::parse(in);
    EXPECT_EQ(j.at("meshes"), 5) << "the tabletop's five objects";

    std::map<std::string, json> imported;
    for (const json& l : j.at("lights")) imported[l.at("name")] = l;
    size_t expected = 0;
    for (const Light& l : now.lights) {
        const PunctualLight p = punctualLight(l);
        if (p.type.empty()) {
            EXPECT_EQ(imported.count(l.name), 0u) << l.name << ": KHR_lights_punctual cannot express it, so no light is written";
            continue;
        }
        ++expected;
        SCOPED_TRACE(l.name + " (" + p.type + ")");
        ASSERT_EQ(imported.count(l.name), 1u) << "Blender did not import the light";
        const json& b = imported[l.name];
        EXPECT_EQ(b.at("type"), p.type == "spot" ? "SPOT" : p.type == "point" ? "POINT" : "SUN");
        const double energy = p.type == "directional" ? p.intensity / PBR_WATTS_TO_LUMENS : p.intensity * 4 * PI / PBR_WATTS_TO_LUMENS;
        EXPECT_NEAR(double(b.at("energy")), energy, 1e-5 * energy);
        for (size_t k = 0; k < 3; ++k) EXPECT_NEAR(double(b.at("color").at(k)), p.color[k], 1e-6);
        if (p.type != "directional") {
            EXPECT_LT(distance(b.at("gltf_location"), l.position), 1e-4) << b.at("gltf_location");
        }
        if (p.type != "point") {
            EXPECT_LT(distance(b.at("gltf_direction"), l.direction), 1e-4) << b.at("gltf_direction");
        }
        if (p.type == "spot") {
            EXPECT_NEAR(double(b.at("spot_size")), 2 * p.outerConeAngle, 1e-5);
            EXPECT_NEAR(double(b.at("spot_blend")), 1 - p.innerConeAngle / p.outerConeAngle, 1e-5);
        }
    }
    EXPECT_GE(expected, 5u) << "the test rig has spot, point, directional and bendy lights";
    EXPECT_EQ(imported.size(), expected) << "no other light was imported (the scene's own were removed)";
}
