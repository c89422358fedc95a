// BendyLights rendered by the engine through EGL:
//  - a straight chain matching the cone renders like the plain spot light (identity);
//  - bent shadows agree with ray casting (Embree) on the deformed scene from each pixel's Q' to
//    the source, on the default scene and on a real asset scene;
//  - adaptive subdivision of the casters matters: without it the agreement drops.

#include "support/Assets.h"
#include "support/DeformedCasters.h"
#include "support/ReadmeBentChain.h"
#include "support/RayCaster.h"

#include <dfb/gbuffer/Baker.h>
#include <dfb/server/BendyChain.h>
#include <dfb/server/Engine.h>

#include <gtest/gtest.h>

using namespace dfb;
using namespace dfb::lightmath;

namespace {

struct Shot {
    Scene scene;
    DeepBuffer buffer;
    std::unique_ptr<Engine> engine;
};

Shot makeShot(const std::string& path, int w, int h) {
    Shot s;
    auto scene = loadScene(path);
    EXPECT_TRUE(scene.ok()) << scene.error().toString();
    s.scene = std::move(scene.value());
    BakeOptions o;
    o.width = w;
    o.height = h;
    auto b = bake(s.scene, o);
    EXPECT_TRUE(b.ok()) << b.error().toString();
    s.buffer = std::move(b.value());
    auto e = Engine::create(s.buffer, shadowCasters(s.scene));
    EXPECT_TRUE(e.ok()) << e.error().toString();
    s.engine = std::move(e.value());
    return s;
}

// Ray-cast reference of a BendyLight's shadow: the casters subdivided (edges at most `h`) and
// deformed Q -> Q' in double, then for each lit pixel a ray from the receiver's own (biased) Q'
// to the source. Returns the fraction of lit pixels where the GPU's shadow mask agrees.
double shadowAgreement(Shot& shot, const Rig& rig, const std::string& lightName, double h, size_t* litOut) {
    const Light& light = *rig.find(lightName);
    const Chain<double> ch = chainFromLight<double>(light);
    test::RayCaster rc;
    test::addDeformedCasters(rc, shot.scene.parts, ch, h, 64);

    auto mask = shot.engine->renderShadowMask(rig, lightName);
    EXPECT_TRUE(mask.ok()) << mask.error().toString();
    const DeepBuffer& g = shot.buffer;
    // The engine's shadow frustum: the cone plus a degree, rounded up to 5 degrees, at most 86.
    const float fovy = 2.f * glm::radians(std::min(5.f * std::ceil((light.coneAngleDeg + 1.f) / 5.f), 86.f));
    const double texelPerDistance = 2.0 * std::tan(0.5 * fovy) / light.shadowMapSize;
    size_t lit = 0, agree = 0;
    for (size_t p = 0; p < g.pixelCount(); ++p) {
        const float reach = mask->rgba[p * 4 + 1];
        if (reach < 0.999f) continue; // the light does not reach the whole pixel
        const float gpuVisible = mask->rgba[p * 4];
        if (gpuVisible > 0.25f && gpuVisible < 0.75f) continue; // on a penumbra edge of the filter
        const glm::dvec3 P(g.position(p)), Ng(g.Ng[p * 3], g.Ng[p * 3 + 1], g.Ng[p * 3 + 2]);
        // The receiver offset the shader uses: shadowBias texels along Ng, at the deformed distance.
        const TubeCoords<double> c0 = inverseMap(ch, P);
        if (!c0.valid) continue;
        const double dist = glm::length(deformedPoint(ch, c0) - ch.p[0]);
        const TubeCoords<double> cb = inverseMap(ch, P + Ng * (light.shadowBias * texelPerDistance * dist));
        if (!cb.valid) continue;
        const glm::dvec3 qb = deformedPoint(ch, cb);
        ++lit;
        const bool refVisible = !rc.occluded(glm::vec3(qb), glm::vec3(ch.p[0]), 1e-4f);
        agree += refVisible == (gpuVisible >= 0.5f);
    }
    *litOut = lit;
    return lit ? double(agree) / double(lit) : 0.0;
}

// A key light bent sideways by about 65 degrees over its second segment.
Light bentKey(const Light& base) {
    Light l = base;
    l.name = "bendy";
    l.shadowMapSize = 2048;
    test::makeReadmeBentChain(l);
    return l;
}

double bendDegrees(const Light& l) {
    const Chain<double> ch = chainFromLight<double>(l);
    return glm::degrees(std::acos(glm::dot(glm::normalize(chainDerivative(ch, 0, 0.0)),
                                           glm::normalize(chainDerivative(ch, ch.segments - 1, 1.0)))));
}

} // namespace

TEST(BendyRender, StraightChainMatchingTheConeRendersLikeTheSpotLight) {
    Shot shot = makeShot(DFB_SOURCE_DIR "/scenes/tabletop.glb", 240, 135);
    const Bounds& b = shot.scene.bounds;
    Rig spot = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    spot.lights.resize(1); // the key alone
    Rig bendy = spot;
    makeStraightChain(bendy.lights[0], 7.f, 3);
    bendy.lights[0].name = "key_bendy"; // a separate cache entry
    EXPECT_EQ(chainWarning(bendy.lights[0]), "");
    auto a = shot.engine->renderLinear(spot);
    ASSERT_TRUE(a.ok()) << a.error().toString();
    auto c = shot.engine->renderLinear(bendy);
    ASSERT_TRUE(c.ok()) << c.error().toString();
    double maxDiff = 0, sumDiff = 0, sum = 0;
    size_t differing = 0;
    for (size_t i = 0; i < a->rgba.size(); i += 4)
        for (int k = 0; k < 3; ++k) {
            const double d = std::abs(double(a->rgba[i + size_t(k)]) - c->rgba[i + size_t(k)]);
            maxDiff = std::max(maxDiff, d);
            sumDiff += d;
            sum += a->rgba[i + size_t(k)];
            differing += d > 1e-3 * (a->rgba[i + size_t(k)] + 1e-3);
        }
    std::printf("straight BendyLight vs spot light: mean relative difference %.2e, max abs %.2e (radiance scale %.3f), "
                "%zu of %zu values differ by more than 0.1%%\n",
                sumDiff / sum, maxDiff, sum / double(a->rgba.size() / 4 * 3), differing, a->rgba.size() / 4 * 3);
    // Tolerance: float evaluation of Q' (about 1e-6 of the scene) moves a handful of shadow-edge
    // samples across a depth comparison; everything else is identical to rounding.
    EXPECT_LT(sumDiff / sum, 1e-3);
    EXPECT_LT(double(differing), 0.002 * double(a->rgba.size() / 4 * 3));
}

TEST(BendyRender, BentShadowsAgreeWithRayCastingOnTheDefaultScene) {
    Shot shot = makeShot(DFB_SOURCE_DIR "/scenes/tabletop.glb", 240, 135);
    const Bounds& b = shot.scene.bounds;
    Rig rig = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    rig.lights = {bentKey(rig.lights[0])};
    const double bend = bendDegrees(rig.lights[0]);
    EXPECT_GE(bend, 60.0);
    EXPECT_EQ(chainWarning(rig.lights[0]), "");
    size_t lit = 0;
    const double agreement = shadowAgreement(shot, rig, "bendy", 0.05, &lit);
    std::printf("tabletop, light bent %.0f deg: shadow map agrees with Embree on %.2f%% of %zu lit pixels\n", bend,
                100 * agreement, lit);
    EXPECT_GT(lit, 2000u);
    EXPECT_GE(agreement, 0.99);
}

TEST(BendyRender, SubdivisionMattersOnARealAssetScene) {
    DFB_REQUIRE_ASSETS();
    // The Cornell box: its blocks and walls are a few large triangles, which a bent light's
    // deformation curves.
    Shot shot = makeShot(test::assetPath("CornellBox-Original.glb"), 160, 160);
    Rig rig;
    Light l;
    l.name = "bendy";
    l.position = {-0.6f, 1.9f, 0.6f};
    l.direction = {0.35f, -1.f, -0.25f};
    l.intensityCd = 5.f;
    l.coneAngleDeg = 35.f;
    l.penumbraDeg = 2.f;
    const float tanTheta = std::tan(glm::radians(l.coneAngleDeg));
    l.type = LightType::Bendy;
    l.controlPoints = {{0.5f, 0.f, 0.f}, {1.0f, 0.f, 0.f}, {1.4f, 0.15f, 0.35f}, {1.6f, 0.4f, 0.9f}};
    l.radii = {0.f, 0.5f * tanTheta, 1.0f * tanTheta, 1.25f * tanTheta, 1.5f * tanTheta};
    l.colors.assign(5, Vec3{1.f, 1.f, 1.f});
    rig.lights = {l};
    const double bend = bendDegrees(l);
    size_t litFine = 0, litCoarse = 0;
    shot.engine->setShadowSubdivisionLimit(64);
    const double fine = shadowAgreement(shot, rig, "bendy", 0.01, &litFine);
    shot.engine->setShadowSubdivisionLimit(1);
    const double coarse = shadowAgreement(shot, rig, "bendy", 0.01, &litCoarse);
    std::printf("Cornell box, light bent %.0f deg: agreement with Embree %.2f%% with adaptive subdivision, %.2f%% "
                "without (of %zu / %zu lit pixels)\n",
                bend, 100 * fine, 100 * coarse, litFine, litCoarse);
    EXPECT_GT(litFine, 2000u);
    EXPECT_GE(fine, 0.99);
    EXPECT_LT(coarse, fine - 0.005) << "subdivision should measurably improve the bent shadows";
}

// The tessellation work bound (BendyShadow.h, MAX_TESS_TRIANGLES): a chain that narrows to a
// waist a tenth of its neighbours' radii (what a local shadow scale drag made of the tabletop's
// key) asks the highest level of most triangles: 4.3 million estimated triangles, 8 s a frame on
// llvmpipe before the bound. The bound lowers that map's limit (FrameStats::subdivisionLowered)
// and the frame comes back; the bent key of the tests above keeps the full limit.
TEST(BendyRender, TessellationWorkIsBoundedOnASharplyNarrowingChain) {
    Shot shot = makeShot(DFB_SOURCE_DIR "/scenes/tabletop.glb", 240, 135);
    const Bounds& b = shot.scene.bounds;
    Rig rig = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    rig.lights = {bentKey(rig.lights[0])};
    FrameStats gentle;
    ASSERT_TRUE(shot.engine->render(rig, &gentle).ok());
    EXPECT_EQ(gentle.shadowMapsRendered, 1);
    EXPECT_EQ(gentle.subdivisionLowered, 0);
    Light& l = rig.lights[0];
    l.radii[2] = 0.1f * l.radii[1];
    l.radii[3] *= 1.5f;
    ++rig.version;
    FrameStats waist;
    auto img = shot.engine->render(rig, &waist);
    ASSERT_TRUE(img.ok()) << img.error().toString();
    EXPECT_EQ(waist.shadowMapsRendered, 1);
    EXPECT_EQ(waist.subdivisionLowered, 1);
    std::printf("waist chain: shadow %.0f ms (the gentle chain's %.0f ms)\n", waist.shadowMs, gentle.shadowMs);
}
