// The environment light on the bundled tabletop (its bowl and vases are concave) against the
// ray-traced reference, as dfb-env-bench measures it: the specular term of a metal version of the
// shot under the sunrise and interior maps, and the diffuse term. Specular history under sunrise
// (mean per-pixel error): the ambient-visibility formula 67 %, the order-3 occlusion towards the
// lobe's dominant direction 27 %, the baked lobe read once (DeepBuffer::envLobe, ENV_LOBE) 11.8 %,
// its rings (DeepBuffer::envRings, ENV_RINGS) the figures below.

#include "bench/BenchShot.h"
#include "bench/EnvFigures.h"

#include <dfb/bvh/TriangleBvh.h>
#include <dfb/server/EnvironmentReference.h>

#include <gtest/gtest.h>

namespace {

using namespace dfb;

// The bundled tabletop's 320 x 180 test shot (with the environment transfer), its scene's rays
// and bounding radius, and the bundled maps' folder.
struct Tabletop {
    bench::BenchShot opened;
    TriangleBvh bvh;
    float radius = 1.f;
    std::string maps = DFB_SOURCE_DIR "/scenes/env";
};

void openTabletop(Tabletop& t) {
    ASSERT_EQ(bench::openBenchShot("env_tabletop_test", DFB_TEST_DATA "/tabletop_320.exr", DFB_SOURCE_DIR "/scenes/tabletop.glb", t.opened), 0);
    ASSERT_TRUE(t.opened.shot.hasEnvTransfer());
    for (const MeshPart& p : t.opened.scene.parts) t.bvh.addMesh(p.positions, p.indices);
    t.bvh.commit();
    const Bounds& b = t.opened.scene.bounds;
    t.radius = 0.5f * glm::length(b.max - b.min);
}

// A shadowed environment light "dome" of the bundled map `map`.
Light shadowedDome(const char* map) {
    Light env;
    env.name = "dome";
    env.type = LightType::Environment;
    env.envMap = map;
    env.shadow = true;
    return env;
}

// Issue 19 point 4's specular target (mean <= 10 %) under both bundled maps, through the lobe's
// rings (format version 7, relight_env.frag ENV_RINGS), and the same shot without them (the whole
// lobe read once, as a version 4-6 shot is lit) measurably worse.
TEST(EnvironmentTabletop, SpecularMeetsTheTargetThroughTheLobesRings) {
    Tabletop t;
    ASSERT_NO_FATAL_FAILURE(openTabletop(t));
    bench::BenchShot& opened = t.opened;
    ASSERT_TRUE(opened.shot.hasEnvLobe()) << "dfb-bake bakes the specular lobe with the transfer";
    ASSERT_TRUE(opened.shot.hasEnvRings()) << "and its rings";
    const DeepBuffer metal = bench::variant(opened.shot, "specular");
    DeepBuffer oneRead = metal;
    oneRead.envRings.clear();
    for (const char* map : {"sunrise.exr", "interior.exr"}) {
        const Light env = shadowedDome(map);
        Rig rig;
        rig.lights = {env};
        // 1,024 rays, as dfb-env-bench's figures: at 256 the reference's own noise adds about a
        // point (interior 9.5 -> 10.6 %).
        auto ref = renderEnvironmentReference(metal, &t.bvh, t.radius, env, t.maps, 1024);
        ASSERT_TRUE(ref.ok()) << ref.error().toString();
        bench::Figures f[2];
        for (int k = 0; k < 2; ++k) {
            auto engine = Engine::create(k == 0 ? metal : oneRead, opened.casters);
            ASSERT_TRUE(engine.ok()) << engine.error().toString();
            engine.value()->setAssetDirectory(t.maps);
            auto fast = engine.value()->renderLightLinear(rig, env.name);
            ASSERT_TRUE(fast.ok()) << fast.error().toString();
            f[k] = bench::compare(fast.value(), ref.value(), metal);
            std::printf("tabletop, metal, %s, %s: specular mean %.2f%% p95 %.2f%% aggregate %.2f%% over %zu pixels\n", map,
                        k == 0 ? "rings" : "one read", 100 * f[k].mean, 100 * f[k].p95, 100 * f[k].aggregate, f[k].pixels);
            EXPECT_GT(f[k].pixels, 20000u);
        }
        SCOPED_TRACE(map);
        EXPECT_LT(f[0].mean, 0.10); // the target
        EXPECT_LT(f[0].p95, 0.30);
        EXPECT_GT(f[1].mean, f[0].mean + 0.015) << "the rings should read the lobe markedly better than one read";
    }
}

// The diffuse term under the interior map, whose light comes from a lamp, a window and a second
// lamp: each is taken out of the map as a directional light with its own shadow map
// (EnvironmentMap.h extractSuns). With the lamp alone taken out, the window's shadows were left
// to the order-3 visibility: 7.1 % mean per-pixel error; with all three 3.8 % (2026-12-06), and
// 3.4 % on the five-band transfer.
TEST(EnvironmentTabletop, InteriorLampsAndWindowShadowTheDiffuse) {
    Tabletop t;
    ASSERT_NO_FATAL_FAILURE(openTabletop(t));
    bench::BenchShot& opened = t.opened;
    const std::string& maps = t.maps;
    const Light env = shadowedDome("interior.exr");
    const DeepBuffer lambert = bench::variant(opened.shot, "diffuse");
    auto engine = Engine::create(lambert, opened.casters);
    ASSERT_TRUE(engine.ok()) << engine.error().toString();
    engine.value()->setAssetDirectory(maps);
    Rig rig;
    rig.lights = {env};
    FrameStats st;
    ASSERT_TRUE(engine.value()->render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 3) << "the lamp, the window and the second lamp";
    auto fast = engine.value()->renderLightLinear(rig, env.name);
    ASSERT_TRUE(fast.ok()) << fast.error().toString();
    auto ref = renderEnvironmentReference(lambert, &t.bvh, t.radius, env, maps, 256);
    ASSERT_TRUE(ref.ok()) << ref.error().toString();
    const bench::Figures f = bench::compare(fast.value(), ref.value(), lambert);
    std::printf("tabletop, Lambert, interior: diffuse mean %.2f%% p95 %.2f%% aggregate %.2f%% over %zu pixels\n", 100 * f.mean,
                100 * f.p95, 100 * f.aggregate, f.pixels);
    EXPECT_GT(f.pixels, 20000u);
    EXPECT_LT(f.mean, 0.05); // issue 19 point 4's diffuse target; 0.071 with the lamp alone
    EXPECT_LT(f.p95, 0.16);  // 0.32 with the lamp alone
}

// The diffuse term under the sunrise map, whose sun is taken out as a directional light: what is
// left to the baked transfer is the sky, whose shadows (under the bowl, between the vases) a
// three-band visibility blurs too far. Five bands (format version 5, the bake's default) halve
// the error: 7.2 % mean per-pixel error at three, 3.7 % at five (256-ray bake and reference).
TEST(EnvironmentTabletop, FiveBandTransferShadowsTheSkyWithinTheTarget) {
    Tabletop t;
    ASSERT_NO_FATAL_FAILURE(openTabletop(t));
    ASSERT_EQ(t.opened.shot.envBands, 5) << "dfb-bake bakes five bands by default";
    const Light env = shadowedDome("sunrise.exr");
    const DeepBuffer five = bench::variant(t.opened.shot, "diffuse");
    // The same shot on three bands: bands 3 and 4 dropped, as a version 4 file or a bake with
    // --env-bands 3 holds it.
    DeepBuffer three = five;
    three.envBands = 3;
    for (size_t s = 0; s < three.sampleCount(); ++s)
        for (int i = 9; i < ENV_TRANSFER_COEFFICIENTS; ++i) three.envTransfer[s * ENV_TRANSFER_COEFFICIENTS + size_t(i)] = 0.f;
    Rig rig;
    rig.lights = {env};
    auto ref = renderEnvironmentReference(five, &t.bvh, t.radius, env, t.maps, 256);
    ASSERT_TRUE(ref.ok()) << ref.error().toString();
    double mean[2] = {0, 0};
    for (int k = 0; k < 2; ++k) {
        const DeepBuffer& shot = k == 0 ? three : five;
        auto engine = Engine::create(shot, t.opened.casters);
        ASSERT_TRUE(engine.ok()) << engine.error().toString();
        engine.value()->setAssetDirectory(t.maps);
        auto fast = engine.value()->renderLightLinear(rig, env.name);
        ASSERT_TRUE(fast.ok()) << fast.error().toString();
        const bench::Figures f = bench::compare(fast.value(), ref.value(), shot);
        std::printf("tabletop, Lambert, sunrise, %d bands: diffuse mean %.2f%% p95 %.2f%% aggregate %.2f%% over %zu pixels\n",
                    shot.envBands, 100 * f.mean, 100 * f.p95, 100 * f.aggregate, f.pixels);
        EXPECT_GT(f.pixels, 20000u);
        mean[k] = f.mean;
    }
    EXPECT_LT(mean[1], 0.05); // issue 19 point 4's diffuse target
    EXPECT_GT(mean[0], 1.5 * mean[1]) << "five bands should shadow the sky markedly better than three";
}

} // namespace
