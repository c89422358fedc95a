// glTF export of the rig (issue 19 point 7): export -> import renders the same frame. The default
// scene is baked once; the rig of every light type is rendered as it is and as loadScene +
// initialRig read it back from the exported file, and the float images (renderLinear: every
// light, exposure applied) and each light's own image must agree within 1e-6, the imported rig
// rendered by an engine of its own.

#include "support/EveryLightRig.h"
#include "support/TabletopShot.h"

#include <dfb/server/GltfExport.h>
#include <dfb/server/InitialRig.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

using namespace dfb;

namespace {

double maxAbsDifference(const ImageF& a, const ImageF& b) {
    if (a.rgba.size() != b.rgba.size()) return INFINITY;
    double d = 0;
    for (size_t i = 0; i < a.rgba.size(); ++i) d = std::max(d, double(std::abs(a.rgba[i] - b.rgba[i])));
    return d;
}

} // namespace

TEST(GltfExportRender, ExportThenImportRendersTheSameFrame) {
    auto t = test::tabletopEngine(160, 90);
    ASSERT_TRUE(t.ok()) << t.error().toString();
    const Rig rig = test::everyLightRig();
    auto glb = exportGltf(DFB_SOURCE_DIR "/scenes/tabletop.glb", rig);
    ASSERT_TRUE(glb.ok()) << glb.error().toString();
    const std::string path = (std::filesystem::temp_directory_path() / "dfb_export_render.glb").string();
    {
        std::ofstream out(path, std::ios::binary);
        out.write(glb->data(), std::streamsize(glb->size()));
    }
    auto scene = loadScene(path);
    ASSERT_TRUE(scene.ok()) << scene.error().toString();
    const Rig back = initialRig(scene.value());
    ASSERT_EQ(back.lights.size(), rig.lights.size());

    // The imported rig on an engine of its own: nothing cached from the original's frame.
    auto fresh = Engine::create(t->shot, t->casters);
    ASSERT_TRUE(fresh.ok()) << fresh.error().toString();
    auto want = t->engine->renderLinear(rig);
    ASSERT_TRUE(want.ok()) << want.error().toString();
    auto got = fresh.value()->renderLinear(back);
    ASSERT_TRUE(got.ok()) << got.error().toString();
    double peak = 0;
    for (float v : want->rgba) peak = std::max(peak, double(v));
    EXPECT_GT(peak, 0.01) << "the rig lights the scene";
    const double diff = maxAbsDifference(want.value(), got.value());
    std::printf("beauty (linear): peak %.4g, max |difference| %.3g over %zu values\n", peak, diff, want->rgba.size());
    EXPECT_LE(diff, 1e-6);
    for (const Light& l : rig.lights) {
        if (!l.enabled) continue;
        auto a = t->engine->renderLightLinear(rig, l.name);
        auto b = fresh.value()->renderLightLinear(back, l.name);
        ASSERT_TRUE(a.ok() && b.ok()) << l.name;
        double lightPeak = 0;
        for (float v : a->rgba) lightPeak = std::max(lightPeak, double(v));
        EXPECT_GT(lightPeak, 0.0) << l.name << " reaches the scene";
        EXPECT_LE(maxAbsDifference(a.value(), b.value()), 1e-6) << l.name;
    }
    std::filesystem::remove(path);
}
