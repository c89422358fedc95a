// Area lights in the engine (issue 18; docs/lighting.md, "Area lights"): one-shot shading
// (relight_area.frag) against its C++ mirror (lightmath/AreaLight.h), the engine's stratified
// reference against the C++ reference, the grid of shadow maps against ray-traced visibility
// (Embree, 16 x 16 rays per pixel to the emitter), caching (an intensity edit rescales, a move
// re-renders the maps), and what the light refuses.

#include "support/AreaShot.h"

#include <dfb/gbuffer/Baker.h>
#include <dfb/lightmath/AreaLight.h>
#include <dfb/lightmath/Ltc.h>
#include <dfb/lightmath/LtcTableData.h>
#include <dfb/protocol/Codec.h>
#include <dfb/server/AreaPattern.h>
#include <dfb/server/Engine.h>

#include <gtest/gtest.h>

#include <glm/gtc/packing.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

using namespace dfb;

namespace {

using namespace test;

enum class Mode { OneShot, Reference, Ltc };

// The GPU's per-sample value against the C++ mirror with the same material, unshadowed.
Errors compareWithCpu(Shot& shot, const Light& l, Mode mode) {
    Rig rig;
    Light unshadowed = l;
    unshadowed.shadow = false;
    unshadowed.areaShading = mode == Mode::Ltc ? AreaShading::Ltc : AreaShading::OneShot;
    rig.lights = {unshadowed};
    const bool reference = mode == Mode::Reference;
    auto img = reference ? shot.engine->renderAreaReference(rig, l.name, 32) : shot.engine->renderLightLinear(rig, l.name);
    EXPECT_TRUE(img.ok()) << img.error().toString();
    Errors e;
    if (!img.ok()) return e;
    auto table = areaPatternTable(l, ".");
    EXPECT_TRUE(table.ok());
    const auto f = areaFrameOf<double>(l);
    forEachSample(shot.g, [&](size_t p, size_t s) {
        const auto [P, N, V, albedo, metallic, roughness, specular] = sampleInputs(shot.g, s);
        const glm::dvec3 want =
            mode == Mode::Reference
                ? lightmath::referenceShading(f, table.value()->table, P, N, V, albedo, metallic, roughness, specular, 32)
            : mode == Mode::Ltc
                ? lightmath::ltcShading(f, lightmath::LTC_TABLE, P, N, V, albedo, metallic, roughness, specular) *
                      lightmath::ltcEmitterColour(table.value()->table, f.disk)
                : lightmath::oneShotShading(f, table.value()->table, P, N, V, albedo, metallic, roughness, specular,
                                            double(l.alphaBeta[0]), double(l.alphaBeta[1]));
        e.add(img->rgba[p * 4], want.x);
    });
    return e;
}

// The engine's visibility (the shadow mask) against 16 x 16 rays from each pixel to the emitter
// (each weighted by what its point gives a Lambert receiver, as the engine weights its layers):
// mean |difference| over the pixels the light reaches, and over the penumbra's (0.02 < ray-traced
// visibility < 0.98).
struct VisibilityError {
    double mean = 0, penumbra = 0;
    size_t pixels = 0, penumbraPixels = 0;
};
VisibilityError visibilityError(Shot& shot, const Light& l) {
    VisibilityError v;
    Rig rig;
    rig.lights = {l};
    auto mask = shot.engine->renderShadowMask(rig, l.name);
    EXPECT_TRUE(mask.ok()) << mask.error().toString();
    if (!mask.ok()) return v;
    const auto f = areaFrameOf<float>(l);
    const float hair = 1e-5f * glm::length(shot.scene.bounds.max - shot.scene.bounds.min);
    forEachSample(shot.g, [&](size_t p, size_t s) {
        const float cov = mask->rgba[p * 4 + 1];
        if (cov < 0.999f) return;
        const float vis = mask->rgba[p * 4] / cov;
        const glm::vec3 P = shot.g.position(s), Ng(shot.g.Ng[s * 3], shot.g.Ng[s * 3 + 1], shot.g.Ng[s * 3 + 2]);
        // The same weighting as the engine's (relight_area.frag areaVisibility): each ray by the
        // light its emitter point gives a Lambert receiver unshadowed.
        double lit = 0.0, all = 0.0;
        for (int j = 0; j < 16; ++j)
            for (int i = 0; i < 16; ++i) {
                const glm::vec3 q = f.centre + f.right * (((i + 0.5f) / 16.f - 0.5f) * f.width) + f.up * (((j + 0.5f) / 16.f - 0.5f) * f.height);
                const glm::vec3 e = q - P;
                const float e2 = glm::dot(e, e);
                const double w = std::max(glm::dot(Ng, e), 0.f) * std::max(-glm::dot(e, f.normal), 0.f) / (e2 * e2);
                if (w <= 0.0) continue;
                all += w;
                lit += w * !shot.rays.occluded(P + Ng * hair, q, 1e-6f);
            }
        if (all <= 0.0) return; // faces away from the whole emitter
        const double ref = lit / all, d = std::abs(vis - ref);
        v.mean += d;
        ++v.pixels;
        if (ref > 0.02 && ref < 0.98) v.penumbra += d, ++v.penumbraPixels;
    });
    v.mean /= double(std::max<size_t>(v.pixels, 1));
    v.penumbra /= double(std::max<size_t>(v.penumbraPixels, 1));
    return v;
}

} // namespace

TEST(AreaLight, OneShotAndReferenceMatchTheirCppMirrors) {
    Shot shot;
    ASSERT_NO_FATAL_FAILURE(makeShot(shot, false));
    for (bool disk : {false, true}) {
        const Light l = panel("panel", 1.2f, disk);
        const Errors one = compareWithCpu(shot, l, Mode::OneShot), ref = compareWithCpu(shot, l, Mode::Reference);
        std::printf("%s: one-shot GPU vs C++ mean %.2e max %.2e; reference GPU vs C++ mean %.2e max %.2e (%zu px)\n",
                    disk ? "disk" : "rect", one.meanRel(), one.maxRel, ref.meanRel(), ref.maxRel, one.n);
        EXPECT_GT(one.n, size_t(WIDTH * HEIGHT / 2));
        // Measured 4-5e-6 mean, 7e-5 max (one-shot: the summed-area table's float corners).
        EXPECT_LT(one.meanRel(), 2e-5);
        EXPECT_LT(ref.meanRel(), 2e-5);
        EXPECT_LT(one.maxRel, 5e-4);
        EXPECT_LT(ref.maxRel, 5e-4);
    }
}

// Linearly transformed cosines (relight_area.frag AREA_LTC, common_ltc.glsl) against Ltc.h, on a
// rough dielectric floor and a glossy metal one, rectangle and disk; and against the reference.
TEST(AreaLight, LtcMatchesItsCppMirror) {
    for (float metallic : {0.f, 1.f}) {
        Shot shot;
        // Roughness values a half float holds exactly: the G-buffer upload's float-to-half rounding
        // and this test's `half` (round to nearest) differ by an ulp otherwise (roughness 0.35:
        // 3e-3 in the glossy lobe's tail, 7e-4 mean).
        ASSERT_NO_FATAL_FAILURE(makeShot(shot, false, metallic, metallic > 0.f ? 0.375f : 0.5f));
        for (bool disk : {false, true})
            for (float height : {0.6f, 1.2f}) {
                const Light l = panel("panel", height, disk);
                const Errors ltc = compareWithCpu(shot, l, Mode::Ltc);
                std::printf("metallic %.0f %s at %.1f: LTC GPU vs C++ mean %.2e max %.2e (%zu px)\n", double(metallic),
                            disk ? "disk" : "rect", double(height), ltc.meanRel(), ltc.maxRel, ltc.n);
                EXPECT_GT(ltc.n, size_t(WIDTH * HEIGHT / 2));
                // Measured 3e-7 - 8e-6 mean, 6e-4 max (float rounding in the glossy lobe's tail).
                EXPECT_LT(ltc.meanRel(), 2e-5);
                EXPECT_LT(ltc.maxRel, 2e-3);
            }
    }
}

// `shading` picks the path: auto is LTC without a pattern, one-shot with one; the two differ; an
// unknown value is refused naming the light and the choices, nothing changed.
TEST(AreaLight, ShadingPropertyPicksThePathAndRefusesUnknownValues) {
    Shot shot;
    ASSERT_NO_FATAL_FAILURE(makeShot(shot, false));
    Rig rig;
    rig.lights = {panel("panel", 1.2f, false)};
    auto image = [&](const char* shading) {
        Rig r = rig;
        EXPECT_TRUE(protocol::applyChanges(r, {{"panel.shading", shading}}).ok());
        auto img = shot.engine->renderLightLinear(r, "panel");
        EXPECT_TRUE(img.ok());
        return img.ok() ? img->rgba : std::vector<float>{};
    };
    const auto autoImage = image("auto"), ltc = image("ltc"), one = image("oneShot");
    ASSERT_FALSE(autoImage.empty());
    EXPECT_EQ(autoImage, ltc);
    double diff = 0.0, sum = 0.0;
    for (size_t i = 0; i < ltc.size(); i += 4) diff += std::abs(ltc[i] - one[i]), sum += ltc[i];
    std::printf("one-shot vs LTC image: mean |difference| / mean %.3f\n", diff / sum);
    EXPECT_GT(diff / sum, 0.02);
    EXPECT_TRUE(protocol::toJson(rig)["lights"][0].contains("shading"));
    EXPECT_EQ(protocol::toJson(rig)["lights"][0]["shading"], "auto");
    Rig r = rig;
    Status s = protocol::applyChanges(r, {{"panel.shading", "exact"}});
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("panel.shading"), std::string::npos) << s.error().message;
    EXPECT_NE(s.error().message.find("\"ltc\""), std::string::npos) << s.error().message;
    EXPECT_EQ(protocol::toJson(r), protocol::toJson(rig));
    // A shading edit re-shades without re-rendering the maps.
    FrameStats st;
    ASSERT_TRUE(shot.engine->render(rig, &st).ok());
    ASSERT_TRUE(protocol::applyChanges(rig, {{"panel.shading", "oneShot"}}).ok());
    ASSERT_TRUE(shot.engine->render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 0);
    EXPECT_EQ(st.lightsShaded, 1);
}

TEST(AreaLight, GridShadowsAgreeWithRayTracedVisibility) {
    Shot shot;
    ASSERT_NO_FATAL_FAILURE(makeShot(shot, true));
    for (int filter : {0, 1})
        for (int m : {1, 2, 4, 8}) {
            Light l = panel("panel", 1.6f, false);
            l.shadowGrid = {m, m};
            l.shadowFilter = filter;
            const VisibilityError v = visibilityError(shot, l);
            std::printf("box, shadow grid %dx%d, filter %d: mean |visibility - ray traced| %.4f over %zu px, %.4f over the %zu "
                        "penumbra px\n", m, m, filter, v.mean, v.pixels, v.penumbra, v.penumbraPixels);
            EXPECT_GT(v.penumbraPixels, 200u);
            // A 1 x 1 grid is a hard shadow from the centre: its penumbra error is the penumbra itself.
            if (m >= 4) {
                EXPECT_LT(v.mean, 0.02);
                EXPECT_LT(v.penumbra, 0.12);
            }
        }
}

// The default scene: its casters are simplified for area lights (Casters::simplify, 104k
// -> about 1k triangles within 0.2 % of the diagonal); the reference rays hit the full meshes.
TEST(AreaLight, SimplifiedCastersKeepTheTabletopsSoftShadows) {
    Shot shot;
    auto scene = loadScene(DFB_SOURCE_DIR "/scenes/tabletop.glb");
    ASSERT_TRUE(scene.ok()) << scene.error().toString();
    shot.scene = std::move(scene.value());
    ASSERT_NO_FATAL_FAILURE(finishShot(shot, BakeOptions{}));
    const Bounds& bb = shot.scene.bounds;
    const Rig rig = defaultRig({bb.min.x, bb.min.y, bb.min.z}, {bb.max.x, bb.max.y, bb.max.z});
    Light l = panel("panel", 0.f, false);
    const glm::vec3 dir = glm::normalize(glm::vec3(rig.lights[0].direction[0], rig.lights[0].direction[1], rig.lights[0].direction[2]));
    const float size = 0.25f * glm::length(bb.max - bb.min);
    const glm::vec3 p = bb.center() - dir * size;
    l.position = {p.x, p.y, p.z};
    l.direction = rig.lights[0].direction;
    l.areaSize = {size, 0.6f * size};
    l.shadowFilter = 0;
    l.shadowGrid = {4, 4};
    const VisibilityError v = visibilityError(shot, l);
    std::printf("tabletop, 4x4, simplified casters: mean |visibility - ray traced| %.4f over %zu px, %.4f over the %zu penumbra px\n",
                v.mean, v.pixels, v.penumbra, v.penumbraPixels);
    EXPECT_GT(v.pixels, 5000u);
    EXPECT_LT(v.mean, 0.03);
    EXPECT_LT(v.penumbra, 0.12);
}

TEST(AreaLight, IntensityEditsRescaleAndMovesRerenderTheMaps) {
    Shot shot;
    ASSERT_NO_FATAL_FAILURE(makeShot(shot, true));
    Rig rig;
    rig.lights = {panel("panel", 1.6f, false)};
    FrameStats st;
    ASSERT_TRUE(shot.engine->render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 1);
    EXPECT_EQ(st.lightsShaded, 1);
    rig.lights[0].intensityCd = 7.f;
    ASSERT_TRUE(shot.engine->render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 0);
    EXPECT_EQ(st.lightsShaded, 0);
    auto scaled = shot.engine->renderLightLinear(rig, "panel");
    rig.lights[0].position[0] += 0.3f;
    ASSERT_TRUE(shot.engine->render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 1);
    EXPECT_EQ(st.lightsShaded, 1);
    rig.lights[0].position[0] -= 0.3f;
    auto back = shot.engine->renderLightLinear(rig, "panel");
    ASSERT_TRUE(scaled.ok() && back.ok());
    double maxDiff = 0.0, peak = 0.0;
    for (size_t i = 0; i < back->rgba.size(); ++i) {
        maxDiff = std::max(maxDiff, double(std::abs(back->rgba[i] - scaled->rgba[i])));
        peak = std::max(peak, double(back->rgba[i]));
    }
    EXPECT_GT(peak, 0.1);
    EXPECT_LE(maxDiff, 1e-5 * peak);
    // Every value finite at the limits of intensity and size.
    rig.lights[0].intensityCd = 1e12f;
    rig.lights[0].areaSize = {1e-4f, 1e-4f};
    auto tiny = shot.engine->renderLightLinear(rig, "panel");
    ASSERT_TRUE(tiny.ok());
    for (float v : tiny->rgba) ASSERT_TRUE(std::isfinite(v));
}

TEST(AreaLight, BadPropertiesAreRefusedNamingTheLightAndProperty) {
    Rig rig;
    rig.lights = {panel("panel", 1.6f, false)};
    auto refused = [&](const char* path, const nlohmann::json& v, const char* words) { expectRefused(rig, path, v, words); };
    refused("panel.size", nlohmann::json::array({0, 1}), "panel.size[0]");
    refused("panel.size", nlohmann::json::array({1, -2}), "panel.size[1]");
    refused("panel.shadowGrid", nlohmann::json::array({17, 4}), "[1, 16]");
    refused("panel.shadowGrid", nlohmann::json::array({4, 0}), "panel.shadowGrid[1]");
    refused("panel.shape", "triangle", "rect");
    refused("panel.pattern", "../etc/passwd", "relative file name");
    // A pattern that is not a readable image: the engine names the light and the pattern.
    Shot shot;
    ASSERT_NO_FATAL_FAILURE(makeShot(shot, false));
    rig.lights[0].pattern = "no-such-pattern.png";
    auto img = shot.engine->renderLightLinear(rig, "panel");
    ASSERT_FALSE(img.ok());
    EXPECT_NE(img.error().message.find("light 'panel': pattern 'no-such-pattern.png'"), std::string::npos) << img.error().message;
}
