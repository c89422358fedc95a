// Interoperability: baked shots open in OpenImageIO's own tools (iinfo, oiiotool from
// openimageio-tools) with the expected channel names, flat and deep.

#include "support/Process.h"

#include <gtest/gtest.h>

#include <filesystem>

using namespace std::chrono_literals;

namespace {
const std::vector<std::string> CHANNELS = [] {
    std::vector<std::string> c = {
        "P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z", "Ng.X", "Ng.Y", "Ng.Z", "T.X", "T.Y", "T.Z", "T.W", "Z",
        "albedo.R", "albedo.G", "albedo.B", "brdf.metallic", "brdf.roughness", "brdf.specular", "brdf.occlusion",
        "sheen.R", "sheen.G", "sheen.B", "sheen.roughness", "coat.weight", "coat.roughness",
        "emission.R", "emission.G", "emission.B", "A", "id.object", "id.material",
        // The specular lobe, baked with the transfer by default.
        "env.lobe.u", "env.lobe.v", "env.lobe.vis"};
    // The environment transfer, which dfb-bake bakes by default, on five bands (--env-bands 5).
    for (int i = 0; i < 25; ++i) c.push_back("env.sh" + std::to_string(i));
    // The near-field horizon, baked by default too (format version 6).
    for (int i = 0; i < 16; ++i) c.push_back("horizon.h" + std::to_string(i));
    return c;
}();
} // namespace

TEST(Interop, IinfoListsEveryChannelOfFlatAndDeepShots) {
    const auto dir = std::filesystem::temp_directory_path() / ("dfb_interop_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    for (int samples : {1, 4}) {
        const std::string shot = (dir / ("shot" + std::to_string(samples) + ".exr")).string();
        auto [rc, out] = dfb::test::run({DFB_BAKE_EXE, DFB_SOURCE_DIR "/scenes/tabletop.glb", "-o", shot, "--width", "64",
                                         "--height", "36", "--samples", std::to_string(samples)});
        ASSERT_EQ(rc, 0) << out;
        auto [irc, info] = dfb::test::run({DFB_IINFO_EXE, "-v", shot});
        ASSERT_EQ(irc, 0) << info;
        for (const std::string& c : CHANNELS) {
            EXPECT_NE(info.find(c + " ("), std::string::npos) << "iinfo does not list " << c << ":\n" << info;
        }
        EXPECT_NE(info.find("worldToCamera"), std::string::npos);
        EXPECT_NE(info.find("worldToNDC"), std::string::npos);
        EXPECT_NE(info.find("dfb.sourceSha256"), std::string::npos);
        EXPECT_NE(info.find("dfb.horizonRadius"), std::string::npos);
        if (samples > 1) {
            EXPECT_NE(info.find("deep"), std::string::npos) << info;
        }
        // oiiotool reads it and extracts (flattening deep data first) a layer by channel names.
        const std::string normals = (dir / ("normals" + std::to_string(samples) + ".exr")).string();
        std::vector<std::string> args = {DFB_OIIOTOOL_EXE, shot};
        if (samples > 1) args.push_back("--flatten");
        args.insert(args.end(), {"--ch", "N.X,N.Y,N.Z", "-o", normals});
        auto [orc, oout] = dfb::test::run(args);
        EXPECT_EQ(orc, 0) << oout;
        auto [vrc, vinfo] = dfb::test::run({DFB_IINFO_EXE, "-v", normals});
        EXPECT_NE(vinfo.find("3 channel"), std::string::npos) << vinfo;
    }
    std::filesystem::remove_all(dir);
}
