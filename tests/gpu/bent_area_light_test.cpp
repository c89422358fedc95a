// Bent area lights in the engine (issue 18 point 7; paper 003 section 4.1; docs/lighting.md,
// "Bent area lights"): the interior BendyLights blended from the four corner chains, each with its
// deformed shadow map, summed. Their unshadowed sum against the C++ sum of the same Lambertian
// emitter cells; straight corner chains against the straight area light with the same shadow
// grid; bent chains moving the shadow; caching; what the light refuses.

#include "support/AreaShot.h"

#include <dfb/lightmath/Brdf.h>
#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Schema.h>
#include <dfb/server/AreaPattern.h>
#include <dfb/server/BentArea.h>

#include <gtest/gtest.h>

#include <glm/gtc/packing.hpp>

#include <cstdio>

using namespace dfb;
using namespace dfb::test;

namespace {

// The area light `panel` as a bent area light with straight corner chains and a cone wide enough
// to hold the whole ground (80 degrees, a hard edge beyond it).
Light bentPanel(float height) {
    Light l = panel("bent", height, false);
    l.type = LightType::BentArea;
    l.coneAngleDeg = 80.f;
    l.penumbraDeg = 0.f;
    l.shadowFilter = 0;
    makeStraightCorners(l, 4.f);
    return l;
}

ImageF lightAlone(Shot& shot, const Light& l) {
    Rig rig;
    rig.lights = {l};
    auto img = shot.engine->renderLightLinear(rig, l.name);
    EXPECT_TRUE(img.ok()) << img.error().toString();
    return img.ok() ? img.value() : ImageF{};
}

// Mean relative difference of channel r over the pixels where `want` is lit.
double meanRelative(const ImageF& got, const ImageF& want, double* maxRel = nullptr) {
    double sumAbs = 0, sum = 0, peak = 0;
    for (size_t p = 0; p * 4 < want.rgba.size(); ++p) peak = std::max(peak, double(want.rgba[p * 4]));
    if (maxRel) *maxRel = 0;
    for (size_t p = 0; p * 4 < want.rgba.size() && p * 4 < got.rgba.size(); ++p) {
        const double w = want.rgba[p * 4], g = got.rgba[p * 4];
        if (w < 1e-3 * peak) continue;
        sumAbs += std::abs(g - w);
        sum += w;
        if (maxRel) *maxRel = std::max(*maxRel, std::abs(g - w) / w);
    }
    return sum > 0 ? sumAbs / sum : 1.0;
}

} // namespace

// The interior lights' sum, unshadowed, is the sum over the m x n emitter cells of a Lambertian
// emitter's cell area x cos(emission) x BRDF cos / d^2 (straight chains: each interior light is
// its cell's point light).
TEST(BentAreaLight, InteriorLightsSumTheEmittersCells) {
    Shot shot;
    ASSERT_NO_FATAL_FAILURE(makeShot(shot, false));
    Light l = bentPanel(1.2f);
    l.shadow = false;
    l.shadowGrid = {3, 2};
    const ImageF img = lightAlone(shot, l);
    const auto f = lightmath::areaFrame<double>({l.position[0], l.position[1], l.position[2]},
                                                {l.direction[0], l.direction[1], l.direction[2]}, double(l.rollDeg),
                                                {l.areaSize[0], l.areaSize[1]}, false);
    const double cell = double(bentAreaCellArea(l, {3, 2}));
    Errors e;
    forEachSample(shot.g, [&](size_t p, size_t s) {
        const auto [P, N, V, albedo, metallic, roughness, specular] = sampleInputs(shot.g, s);
        double want = 0.0;
        for (int j = 0; j < 2; ++j)
            for (int i = 0; i < 3; ++i) {
                const glm::dvec3 q = f.centre + f.right * (((i + 0.5) / 3.0 - 0.5) * f.width) + f.up * (((j + 0.5) / 2.0 - 0.5) * f.height);
                const glm::dvec3 d = q - P;
                const double d2 = glm::dot(d, d);
                const glm::dvec3 L = d / std::sqrt(d2);
                const double emit = std::max(-glm::dot(L, f.normal), 0.0);
                want += cell * emit / d2 *
                        lightmath::evaluateBrdfCos(N, L, V, albedo, metallic, roughness, specular).x;
            }
        e.add(img.rgba[p * 4], want);
    });
    std::printf("bent area 3x2, straight, unshadowed: GPU vs C++ cells mean %.2e max %.2e (%zu px)\n", e.meanRel(), e.maxRel, e.n);
    EXPECT_GT(e.n, size_t(WIDTH * HEIGHT / 2));
    EXPECT_LT(e.meanRel(), 1e-4);
    EXPECT_LT(e.maxRel, 2e-3);
}

// Paper 003 section 4.1 with straight chains is the straight area light: the same m x n points
// over the emitter, each a hard shadow. Against the area light's stratified reference (32 x 32
// cells, its 4 x 4 grid of maps) and its shadow mask.
TEST(BentAreaLight, StraightChainsRenderAsTheAreaLight) {
    Shot shot;
    ASSERT_NO_FATAL_FAILURE(makeShot(shot, true));
    const Light bent = bentPanel(1.6f);
    Light area = panel("panel", 1.6f, false);
    area.shadowFilter = 0;
    Rig rig;
    rig.lights = {area};
    auto ref = shot.engine->renderAreaReference(rig, "panel", 32);
    ASSERT_TRUE(ref.ok()) << ref.error().toString();
    auto areaMask = shot.engine->renderShadowMask(rig, "panel");
    ASSERT_TRUE(areaMask.ok());
    auto areaImage = shot.engine->renderLightLinear(rig, "panel"); // as it renders: uniform, so LTC
    ASSERT_TRUE(areaImage.ok());
    const ImageF got = lightAlone(shot, bent);
    rig.lights = {bent};
    auto bentMask = shot.engine->renderShadowMask(rig, "bent");
    ASSERT_TRUE(bentMask.ok()) << bentMask.error().toString();
    double maxRel = 0;
    const double rel = meanRelative(got, ref.value(), &maxRel);
    double maskDiff = 0;
    size_t maskPixels = 0, shadowed = 0;
    for (size_t p = 0; p * 4 < got.rgba.size(); ++p) {
        const float ca = areaMask->rgba[p * 4 + 1], cb = bentMask->rgba[p * 4 + 1];
        if (ca < 0.999f || cb < 0.999f) continue;
        const double va = areaMask->rgba[p * 4] / ca, vb = bentMask->rgba[p * 4] / cb;
        maskDiff += std::abs(va - vb);
        ++maskPixels;
        shadowed += va < 0.9;
    }
    maskDiff /= double(std::max<size_t>(maskPixels, 1));
    const double relLtc = meanRelative(got, areaImage.value());
    std::printf("straight bent area 4x4 vs area light reference: mean relative %.4f, max %.3f; vs the area light as it renders "
                "(LTC) %.4f; visibility mean |diff| %.4f over %zu px (%zu in shadow)\n", rel, maxRel, relLtc, maskDiff, maskPixels,
                shadowed);
    EXPECT_LT(relLtc, 0.02);
    EXPECT_GT(shadowed, 300u);
    EXPECT_LT(rel, 0.02);
    EXPECT_LT(maskDiff, 0.01);
}

// Bending the four chains sideways carries the light, and the box's shadow, along them.
TEST(BentAreaLight, BentChainsMoveTheShadow) {
    Shot shot;
    ASSERT_NO_FATAL_FAILURE(makeShot(shot, true));
    Light l = bentPanel(1.6f);
    l.rollDeg = 0.f;
    l.coneAngleDeg = 30.f;
    makeStraightCorners(l, 4.f);
    auto shadowCentroid = [&](const Light& light) {
        Rig rig;
        rig.lights = {light};
        auto mask = shot.engine->renderShadowMask(rig, light.name);
        EXPECT_TRUE(mask.ok()) << mask.error().toString();
        double sx = 0, sw = 0;
        for (int y = 0; y < HEIGHT; ++y)
            for (int x = 0; x < WIDTH; ++x) {
                const size_t p = size_t(y * WIDTH + x);
                const float cov = mask->rgba[p * 4 + 1];
                if (cov < 0.999f) continue;
                const double dark = 1.0 - mask->rgba[p * 4] / cov;
                sx += dark * x;
                sw += dark;
            }
        return sw > 0 ? sx / sw : -1.0;
    };
    const double straight = shadowCentroid(l);
    // Every corner's chain: out along the normal, then turning smoothly (C1 at the join, a radius
    // of curvature of 5.2 against tube radii of at most 2.3) towards the emitter's right.
    for (int c = 0; c < BENT_AREA_CORNERS; ++c) {
        l.cornerPoints[size_t(c * 4 + 0)] = {1.f, 0.f, 0.f};
        l.cornerPoints[size_t(c * 4 + 1)] = {2.f, 0.f, 0.75f};
        l.cornerPoints[size_t(c * 4 + 2)] = {3.f, 0.f, 1.5f};
        l.cornerPoints[size_t(c * 4 + 3)] = {4.f, 0.f, 3.f};
    }
    EXPECT_EQ(bentAreaWarning(l), "");
    const double bent = shadowCentroid(l);
    std::printf("shadow centroid x: straight %.1f px, bent %.1f px\n", straight, bent);
    ASSERT_GT(straight, 0.0);
    // The light arrives slanted by the bend: the box's shadow moves by several pixels.
    EXPECT_GT(std::abs(bent - straight), 3.0);
    const ImageF img = lightAlone(shot, l);
    for (float v : img.rgba) ASSERT_TRUE(std::isfinite(v));
}

TEST(BentAreaLight, IntensityRescalesAndCornerEditsRerenderTheMaps) {
    Shot shot;
    ASSERT_NO_FATAL_FAILURE(makeShot(shot, true));
    Rig rig;
    rig.lights = {bentPanel(1.6f)};
    rig.lights[0].shadowGrid = {2, 2};
    FrameStats st;
    ASSERT_TRUE(shot.engine->render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 1);
    EXPECT_EQ(st.lightsShaded, 1);
    const auto first = shot.engine->renderLightLinear(rig, "bent");
    rig.lights[0].intensityCd = 5.f;
    ASSERT_TRUE(shot.engine->render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 0);
    EXPECT_EQ(st.lightsShaded, 0);
    const auto scaled = shot.engine->renderLightLinear(rig, "bent");
    ASSERT_TRUE(first.ok() && scaled.ok());
    double peak = 0, maxDiff = 0;
    for (size_t i = 0; i < first->rgba.size(); i += 4) {
        peak = std::max(peak, double(scaled->rgba[i]));
        maxDiff = std::max(maxDiff, std::abs(double(scaled->rgba[i]) - 5.0 * double(first->rgba[i])));
    }
    EXPECT_GT(peak, 0.1);
    EXPECT_LE(maxDiff, 1e-5 * peak);
    rig.lights[0].cornerPoints[1] = {2.f, 0.2f, 0.f};
    ASSERT_TRUE(shot.engine->render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 1);
    EXPECT_EQ(st.lightsShaded, 1);
    // A preview takes fewer interior lights; the refined frame re-renders them all.
    rig.lights[0].shadowGrid = {4, 4};
    shot.engine->setPreview(true);
    ASSERT_TRUE(shot.engine->render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 1);
    shot.engine->setPreview(false);
    ASSERT_TRUE(shot.engine->render(rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 1);
    EXPECT_EQ(st.lightsShaded, 1);
}

TEST(BentAreaLight, BadPropertiesAreRefusedNamingTheLightAndProperty) {
    Rig rig;
    rig.lights = {bentPanel(1.6f)};
    auto refused = [&](const char* path, const nlohmann::json& v, const char* words) { expectRefused(rig, path, v, words); };
    nlohmann::json pts = protocol::toJson(rig)["lights"][0]["cornerPoints"];
    ASSERT_EQ(pts.size(), 16u);
    // Corner 2's first segment collapsed onto its corner: a degenerate corner chain.
    nlohmann::json degenerate = pts;
    degenerate[8] = {0, 0, 0};
    degenerate[9] = {0, 0, 0};
    refused("bent.cornerPoints", degenerate, "bent.cornerPoints: corner 2's segment 0 has zero length");
    refused("bent.cornerPoints", nlohmann::json::array({{1, 0, 0}, {2, 0, 0}}), "4 chains");
    refused("bent.ccp[16]", nlohmann::json::array({1, 0, 0}), "bent.ccp[16]: index out of range 0..15");
    refused("bent.cr[3]", -1, "bent.cr[3]");
    refused("bent.cornerRadii", nlohmann::json::array({1, 2}), "expected 20 radii");
    refused("bent.shadowGrid", nlohmann::json::array({17, 4}), "[1, 16]");
    refused("bent.size", nlohmann::json::array({0, 1}), "bent.size[0]");
    refused("bent.ccp[0]", nlohmann::json::array({0, 0, std::nan("")}), "bent.ccp[0]");
    // Corner chains belong to bent area lights only.
    rig.lights.push_back(panel("panel", 1.6f, false));
    refused("panel.cornerPoints", pts, "applies to bent area lights only");
    // Switching a spot to a bent area light gives it straight corners that the engine renders.
    Rig spot;
    spot.lights = {Light{}};
    spot.lights[0].name = "s";
    ASSERT_TRUE(protocol::applyChanges(spot, {{"s.type", "bentArea"}}).ok());
    EXPECT_EQ(spot.lights[0].cornerPoints.size(), 16u);
    EXPECT_EQ(spot.lights[0].cornerRadii.size(), 20u);
    EXPECT_LE(spot.lights[0].shadowMapSize, protocol::AREA_DEFAULT_MAP_SIZE);
}
