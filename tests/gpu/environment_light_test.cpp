// Environment lights in the engine (issue 19; docs/lighting.md, "Environment light"): the white
// furnace (a constant environment: Lambert gives the albedo, the split sum the DFG table's
// integral), diffuse against the exact cosine integral of a map that order-3 spherical harmonics
// hold exactly (any rotation), a yaw of 90 degrees against the same map shifted by a quarter turn
// (specular included), caching (a rotation re-shades the environment alone, an intensity edit
// nothing), and what the engine and the image reader refuse.

#include "support/AreaShot.h"

#include "engine/EnvironmentMap.h"

#include <dfb/lightmath/Environment.h>
#include <dfb/server/EnvironmentReference.h>
#include <dfb/server/ImageCodec.h>
#include <dfb/server/Outputs.h>

#include <OpenImageIO/imageio.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>

using namespace dfb;

namespace {

using namespace test;

namespace fs = std::filesystem;

// A fresh folder for this test's maps.
fs::path mapFolder() {
    const fs::path dir = fs::temp_directory_path() / ("dfb_env_test_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    return dir;
}

// Writes a w x h lat-long map whose texel (i, j) is f(direction at its centre), as 32-bit float
// EXR (or `format` for the refusal tests).
void writeMap(const fs::path& path, int w, int h, const std::function<glm::vec3(const glm::dvec3&)>& f,
              OIIO::TypeDesc format = OIIO::TypeDesc::FLOAT) {
    std::vector<float> px(size_t(w) * size_t(h) * 3);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const glm::vec3 c = f(lightmath::envDirection((i + 0.5) / w, (j + 0.5) / h));
            for (int k = 0; k < 3; ++k) px[(size_t(j) * size_t(w) + size_t(i)) * 3 + size_t(k)] = c[k];
        }
    auto out = OIIO::ImageOutput::create(path.string());
    ASSERT_TRUE(out) << OIIO::geterror();
    OIIO::ImageSpec spec(w, h, 3, format);
    ASSERT_TRUE(out->open(path.string(), spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, px.data()));
    out->close();
}

// What the engine reads: the G-buffer's material layers as half float.
double asHalf(float v) { return double(glm::unpackHalf1x16(glm::packHalf1x16(v))); }

Light environment(const char* name, const std::string& map = "") {
    Light l;
    l.name = name;
    l.type = LightType::Environment;
    l.envMap = map;
    l.intensityCd = 1.f;
    l.shadow = false;
    return l;
}

// The shot with every sample's specular level set to `specular` (0: pure Lambert), on its own
// engine reading maps from `dir`.
std::unique_ptr<Engine> engineWithSpecular(const Shot& s, float specular, const fs::path& dir) {
    DeepBuffer g = s.g;
    for (size_t i = 0; i < g.A.size(); ++i) g.brdf[i * 4 + 2] = specular;
    auto e = Engine::create(g, shadowCasters(s.scene));
    EXPECT_TRUE(e.ok()) << e.error().toString();
    if (!e.ok()) return nullptr;
    e.value()->setAssetDirectory(dir.string());
    return std::move(e.value());
}

// The exact diffuse irradiance over pi of radiance L (a function of the world direction) at
// normal N: integral of L(w) max(0, N.w) / pi dw, by a fine midpoint rule in (theta, phi).
double cosineIntegral(const std::function<double(const glm::dvec3&)>& L, const glm::dvec3& N) {
    constexpr int T = 256, P = 512;
    double sum = 0;
    for (int j = 0; j < T; ++j) {
        const double theta = lightmath::ENV_PI * (j + 0.5) / T, st = std::sin(theta);
        for (int i = 0; i < P; ++i) {
            const double phi = 2 * lightmath::ENV_PI * (i + 0.5) / P;
            const glm::dvec3 w(st * std::cos(phi), std::cos(theta), st * std::sin(phi));
            sum += L(w) * std::max(0.0, glm::dot(N, w)) * st;
        }
    }
    return sum * (lightmath::ENV_PI / T) * (2 * lightmath::ENV_PI / P) / lightmath::ENV_PI;
}

TEST(EnvironmentLight, WhiteFurnace) {
    Shot s;
    ASSERT_NO_FATAL_FAILURE(makeShot(s, true, 0.f, 0.5f));
    const fs::path dir = mapFolder();
    Rig rig;
    rig.lights = {environment("env")};
    // Lambert (specular level 0): the constant environment of radiance 1 gives the albedo.
    {
        auto e = engineWithSpecular(s, 0.f, dir);
        ASSERT_TRUE(e);
        auto img = e->renderLightLinear(rig, "env");
        ASSERT_TRUE(img.ok()) << img.error().toString();
        Errors err;
        forEachSample(s.g, [&](size_t p, size_t i) { err.add(img->rgba[p * 4 + 1], asHalf(s.g.albedo[i * 3 + 1])); });
        std::printf("white furnace, Lambert: mean %.2e max %.2e relative over %zu pixels\n", err.meanRel(), err.maxRel, err.n);
        EXPECT_GT(err.n, 10000u);
        // The exact irradiance grid's texel-centre quadrature of the clamped cosine leaves 3e-4
        // (Environment.h envIrradianceMap, from the map's 128 x 64 copy).
        EXPECT_LT(err.maxRel, 5e-4);
    }
    // glTF's default dielectric (specular level 0.5: F0 0.04, F90 1): (1 - F(N.v)) albedo plus
    // F0 A + F90 B of the DFG integral (without the table's interpolation).
    {
        auto img = s.engine->renderLightLinear(rig, "env");
        ASSERT_TRUE(img.ok()) << img.error().toString();
        Errors err;
        const glm::dvec3 eye(0.f, 4.f, 4.5f);
        forEachSample(s.g, [&](size_t p, size_t i) {
            const glm::dvec3 P = glm::dvec3(s.g.position(i)), N = glm::normalize(glm::dvec3(s.g.normal(i)));
            const double NdotV = std::clamp(glm::dot(N, glm::normalize(eye - P)), 1e-4, 1.0);
            const double roughness = asHalf(s.g.brdf[i * 4 + 1]), specular = asHalf(s.g.brdf[i * 4 + 2]),
                         albedo = asHalf(s.g.albedo[i * 3 + 1]);
            const double F = 0.08 * specular + (std::min(2 * specular, 1.0) - 0.08 * specular) * std::pow(1 - NdotV, 5.0);
            const glm::dvec2 ab = lightmath::dfgIntegral(NdotV, roughness, 4096);
            err.add(img->rgba[p * 4 + 1], (1 - F) * albedo + 0.08 * specular * ab.x + std::min(2 * specular, 1.0) * ab.y);
        });
        std::printf("white furnace, dielectric: mean %.2e max %.2e relative\n", err.meanRel(), err.maxRel);
        EXPECT_LT(err.meanRel(), 2e-3);
        EXPECT_LT(err.maxRel, 1e-2);
    }
}

// L(d) = 1 + 0.5 d.y + 0.3 d.x d.z + 0.2 (d.x^2 - d.y^2): bands 0..2 only, so the order-3
// expansion and the clamped-cosine convolution are exact (Ramamoorthi and Hanrahan 2001) and
// what is left is the map's texels.
double bandLimited(const glm::dvec3& d) { return 1.0 + 0.5 * d.y + 0.3 * d.x * d.z + 0.2 * (d.x * d.x - d.y * d.y); }

TEST(EnvironmentLight, DiffuseMatchesTheCosineIntegralAtAnyRotation) {
    Shot s;
    ASSERT_NO_FATAL_FAILURE(makeShot(s, true, 0.f, 0.5f));
    const fs::path dir = mapFolder();
    ASSERT_NO_FATAL_FAILURE(writeMap(dir / "band.exr", 256, 128, [](const glm::dvec3& d) {
        const float v = float(bandLimited(d));
        return glm::vec3(v, 0.5f * v, 0.25f * v);
    }));
    auto e = engineWithSpecular(s, 0.f, dir);
    ASSERT_TRUE(e);
    for (const std::array<float, 3> rotation : {std::array<float, 3>{0.f, 0.f, 0.f}, std::array<float, 3>{30.f, 20.f, 10.f}}) {
        Light l = environment("env", "band.exr");
        l.envRotationDeg = rotation;
        Rig rig;
        rig.lights = {l};
        auto img = e->renderLightLinear(rig, "env");
        ASSERT_TRUE(img.ok()) << img.error().toString();
        const glm::dmat3 R = lightmath::envRotation(rotation);
        const auto world = [&](const glm::dvec3& w) { return bandLimited(glm::transpose(R) * w); };
        // The shot's normals are the ground's and the box's front face's: one integral each.
        std::map<std::array<int, 3>, double> integrals;
        Errors err;
        forEachSample(s.g, [&](size_t p, size_t i) {
            const glm::dvec3 N = glm::normalize(glm::dvec3(s.g.normal(i)));
            const std::array<int, 3> key{int(std::lround(N.x * 100)), int(std::lround(N.y * 100)), int(std::lround(N.z * 100))};
            auto it = integrals.find(key);
            if (it == integrals.end()) it = integrals.emplace(key, cosineIntegral(world, N)).first;
            err.add(img->rgba[p * 4], asHalf(s.g.albedo[i * 3]) * it->second);
            err.add(img->rgba[p * 4 + 2], 0.25 * asHalf(s.g.albedo[i * 3 + 2]) * it->second);
        });
        std::printf("diffuse vs the cosine integral, rotation (%g, %g, %g): mean %.2e max %.2e over %zu normals\n",
                    double(rotation[0]), double(rotation[1]), double(rotation[2]), err.meanRel(), err.maxRel, integrals.size());
        EXPECT_GE(integrals.size(), 2u);
        EXPECT_LT(err.maxRel, 5e-4);
    }
}

// A map with a bright, small patch (far from band-limited) and its copy shifted by a quarter
// turn: a yaw of 90 degrees (envRotation: world -Z -> -X) must render the shifted file unturned,
// prefiltered specular included.
TEST(EnvironmentLight, YawEqualsTheShiftedMap) {
    Shot s;
    ASSERT_NO_FATAL_FAILURE(makeShot(s, true, 0.f, 0.3f));
    const fs::path dir = mapFolder();
    const auto patch = [](const glm::dvec3& d) {
        const double k = std::max(0.0, glm::dot(d, glm::normalize(glm::dvec3(0.6, 0.5, -0.6))));
        return glm::vec3(float(0.2 + 20.0 * std::pow(k, 40.0)), float(0.3 + 5.0 * std::pow(k, 10.0)), 0.4f);
    };
    constexpr int W = 64, H = 32;
    ASSERT_NO_FATAL_FAILURE(writeMap(dir / "patch.exr", W, H, patch));
    // Shifted: column i holds the original's column i + W/4 (world -X, u = 0.25, shows the
    // original's centre column, u = 0.5).
    ASSERT_NO_FATAL_FAILURE(writeMap(dir / "shifted.exr", W, H, [&](const glm::dvec3& d) {
        const glm::dvec2 uv = lightmath::envLatLong(d);
        return patch(lightmath::envDirection(uv.x + 0.25, uv.y));
    }));
    s.engine->setAssetDirectory(dir.string());
    Light turned = environment("env", "patch.exr");
    turned.envRotationDeg = {90.f, 0.f, 0.f};
    Rig a, b;
    a.lights = {turned};
    b.lights = {environment("env", "shifted.exr")};
    auto ia = s.engine->renderLightLinear(a, "env");
    auto ib = s.engine->renderLightLinear(b, "env");
    ASSERT_TRUE(ia.ok()) << ia.error().toString();
    ASSERT_TRUE(ib.ok()) << ib.error().toString();
    Errors err;
    forEachSample(s.g, [&](size_t p, size_t) {
        for (int c = 0; c < 3; ++c) err.add(ia->rgba[p * 4 + size_t(c)], ib->rgba[p * 4 + size_t(c)]);
    });
    // And it is not the unturned map (the comparison could fail).
    Rig c;
    c.lights = {environment("env", "patch.exr")};
    auto ic = s.engine->renderLightLinear(c, "env");
    ASSERT_TRUE(ic.ok());
    Errors unturned;
    forEachSample(s.g, [&](size_t p, size_t) { unturned.add(ic->rgba[p * 4], ib->rgba[p * 4]); });
    std::printf("yaw 90 vs shifted map: mean %.2e max %.2e; unturned vs shifted: mean %.2e\n", err.meanRel(), err.maxRel,
                unturned.meanRel());
    EXPECT_LT(err.meanRel(), 1e-4);
    EXPECT_LT(err.maxRel, 2e-3);
    EXPECT_GT(unturned.meanRel(), 0.05);
}

TEST(EnvironmentLight, RotationReshadesItAloneAndIntensityNothing) {
    Shot s;
    ASSERT_NO_FATAL_FAILURE(makeShot(s, true));
    Light spot;
    spot.name = "key";
    spot.position = {2.f, 4.f, 2.f};
    spot.direction = {-0.4f, -0.8f, -0.4f};
    spot.shadowMapSize = 512;
    Rig rig;
    rig.lights = {environment("env"), spot};
    rig.lights[0].shadow = true; // no baked visibility here: shaded unshadowed, still no map
    FrameStats st;
    ASSERT_TRUE(s.engine->render(rig, &st).ok());
    EXPECT_EQ(st.lightsShaded, 2);
    EXPECT_EQ(st.shadowMapsRendered, 1);
    rig.lights[0].envRotationDeg = {45.f, 0.f, 0.f};
    st = {};
    ASSERT_TRUE(s.engine->render(rig, &st).ok());
    EXPECT_EQ(st.lightsShaded, 1);
    EXPECT_EQ(st.shadowMapsRendered, 0);
    rig.lights[0].intensityCd = 3.f;
    rig.lights[0].color = {1.f, 0.5f, 0.2f};
    st = {};
    ASSERT_TRUE(s.engine->render(rig, &st).ok());
    EXPECT_EQ(st.lightsShaded, 0);
    EXPECT_EQ(st.shadowMapsRendered, 0);
    // The rescaled image is the freshly shaded one.
    auto cached = s.engine->renderLightLinear(rig, "env");
    Shot fresh;
    ASSERT_NO_FATAL_FAILURE(makeShot(fresh, true));
    auto want = fresh.engine->renderLightLinear(rig, "env");
    ASSERT_TRUE(cached.ok() && want.ok());
    double worst = 0;
    for (size_t i = 0; i < cached->rgba.size(); ++i)
        worst = std::max(worst, double(std::abs(cached->rgba[i] - want->rgba[i])) / std::max(1e-6, double(std::abs(want->rgba[i]))));
    EXPECT_LT(worst, 1e-5);
}

TEST(EnvironmentLight, BadMapsAreRefusedByName) {
    const fs::path dir = mapFolder();
    const auto grey = [](const glm::dvec3&) { return glm::vec3(0.5f); };
    ASSERT_NO_FATAL_FAILURE(writeMap(dir / "ldr16.png", 16, 8, grey, OIIO::TypeDesc::UINT16));
    ASSERT_NO_FATAL_FAILURE(writeMap(dir / "huge.exr", MAX_ENV_MAP_WIDTH + 8, 2, grey, OIIO::TypeDesc::HALF));
    ASSERT_NO_FATAL_FAILURE(writeMap(dir / "nan.exr", 16, 8, [](const glm::dvec3& d) {
        return d.y > 0.9 ? glm::vec3(std::nanf("")) : glm::vec3(1.f);
    }));
    auto png = checkHdrImageFile((dir / "ldr16.png").string(), MAX_ENV_MAP_WIDTH, MAX_ENV_MAP_HEIGHT);
    ASSERT_FALSE(png.ok());
    EXPECT_NE(png.error().message.find("not float"), std::string::npos) << png.error().message;
    auto huge = checkHdrImageFile((dir / "huge.exr").string(), MAX_ENV_MAP_WIDTH, MAX_ENV_MAP_HEIGHT);
    ASSERT_FALSE(huge.ok());
    EXPECT_NE(huge.error().message.find("at most 8192x4096"), std::string::npos) << huge.error().message;
    EXPECT_TRUE(checkHdrImageFile((dir / "nan.exr").string(), MAX_ENV_MAP_WIDTH, MAX_ENV_MAP_HEIGHT).ok()); // the header is fine
    auto nan = readHdrImage((dir / "nan.exr").string(), MAX_ENV_MAP_WIDTH, MAX_ENV_MAP_HEIGHT);
    ASSERT_FALSE(nan.ok());
    EXPECT_NE(nan.error().message.find("texel ("), std::string::npos) << nan.error().message;

    // The engine names the light and the map, and renders the next good rig.
    Shot s;
    ASSERT_NO_FATAL_FAILURE(makeShot(s, false));
    s.engine->setAssetDirectory(dir.string());
    for (const char* bad : {"nan.exr", "missing.exr", "ldr16.png"}) {
        Rig rig;
        rig.lights = {environment("dome", bad)};
        auto img = s.engine->renderLinear(rig);
        ASSERT_FALSE(img.ok()) << bad;
        EXPECT_NE(img.error().message.find("light 'dome': map '" + std::string(bad) + "'"), std::string::npos) << img.error().message;
    }
    Rig good;
    good.lights = {environment("dome")};
    EXPECT_TRUE(s.engine->renderLinear(good).ok());
}

} // namespace

namespace {

// The brute-force reference (EnvironmentReference.h) where the fast path is exact: a Lambert
// shot under the band-limited map, unshadowed, and the white furnace of the dielectric.
TEST(EnvironmentLight, ReferenceAgreesWhereTheFastPathIsExact) {
    Shot s;
    ASSERT_NO_FATAL_FAILURE(makeShot(s, true, 0.f, 0.5f));
    const fs::path dir = mapFolder();
    ASSERT_NO_FATAL_FAILURE(writeMap(dir / "band.exr", 256, 128, [](const glm::dvec3& d) { return glm::vec3(float(bandLimited(d))); }));
    DeepBuffer lambert = s.g;
    for (size_t i = 0; i < lambert.A.size(); ++i) lambert.brdf[i * 4 + 2] = 0.f;
    auto e = engineWithSpecular(s, 0.f, dir);
    ASSERT_TRUE(e);
    Light l = environment("env", "band.exr");
    l.envRotationDeg = {30.f, 20.f, 10.f};
    Rig rig;
    rig.lights = {l};
    auto fast = e->renderLightLinear(rig, "env");
    auto ref = renderEnvironmentReference(lambert, nullptr, 6.f, l, dir.string(), 384);
    ASSERT_TRUE(fast.ok() && ref.ok()) << (ref.ok() ? "" : ref.error().toString());
    Errors err;
    forEachSample(s.g, [&](size_t p, size_t) { err.add(fast->rgba[p * 4], ref->rgba[p * 4]); });
    std::printf("band-limited map, Lambert: fast path vs reference mean %.2e max %.2e relative\n", err.meanRel(), err.maxRel);
    EXPECT_LT(err.meanRel(), 5e-3);

    // The dielectric (specular 0.5, roughness 0.5) in the white furnace: what is left is the
    // diffuse weight's Fresnel taken at N.v instead of per direction (measured 2.2 % mean, up to
    // 12 % at grazing views) and the reference's noise (0.2 % mean on the Lambert shot above).
    Rig white;
    white.lights = {environment("env")};
    auto fastWhite = s.engine->renderLightLinear(white, "env");
    auto refWhite = renderEnvironmentReference(s.g, nullptr, 6.f, white.lights[0], dir.string(), 384);
    ASSERT_TRUE(fastWhite.ok() && refWhite.ok());
    Errors werr;
    forEachSample(s.g, [&](size_t p, size_t) { werr.add(fastWhite->rgba[p * 4], refWhite->rgba[p * 4]); });
    std::printf("white furnace, dielectric: fast path vs reference mean %.2e max %.2e relative\n", werr.meanRel(), werr.maxRel);
    EXPECT_LT(werr.meanRel(), 3e-2);
}

} // namespace

namespace {

// With the shot's baked visibility (BakeOptions::envRays): the box shadows the ground under the
// soft courtyard map, and the fast path (order-3 transfer) agrees with the ray-traced reference
// within the 5 % for diffuse; unshadowed it would not.
TEST(EnvironmentLight, BakedVisibilityShadowsLikeTheReference) {
    Shot s;
    ShotOptions opt;
    opt.boxMin = {-0.6f, 0.f, -0.6f};
    opt.boxMax = {0.6f, 0.8f, 0.6f};
    opt.specularFactor = 0.f; // Lambert: the diffuse term alone
    opt.roughness = 1.f;
    opt.envRays = 256;
    ASSERT_NO_FATAL_FAILURE(makeShot(s, opt));
    ASSERT_TRUE(s.g.hasEnvTransfer());
    const std::string maps = DFB_SOURCE_DIR "/scenes/env";
    s.engine->setAssetDirectory(maps);
    Light l = environment("env", "courtyard.exr");
    l.shadow = true;
    Rig rig;
    rig.lights = {l};
    auto fast = s.engine->renderLightLinear(rig, "env");
    ASSERT_TRUE(fast.ok()) << fast.error().message;
    rig.lights[0].shadow = false;
    auto open = s.engine->renderLightLinear(rig, "env");
    ASSERT_TRUE(open.ok());
    const float radius = 0.5f * glm::length(s.scene.bounds.max - s.scene.bounds.min);
    auto ref = renderEnvironmentReference(s.g, &s.rays, radius, l, maps, 1024);
    ASSERT_TRUE(ref.ok()) << ref.error().toString();
    Errors shadowed, unshadowed;
    double nearBox = 0, far = 0;
    size_t nNear = 0, nFar = 0;
    forEachSample(s.g, [&](size_t p, size_t i) {
        shadowed.add(fast->rgba[p * 4 + 1], ref->rgba[p * 4 + 1]);
        unshadowed.add(open->rgba[p * 4 + 1], ref->rgba[p * 4 + 1]);
        const glm::vec3 P = s.g.position(i);
        if (s.g.objectId[i] != 1) return;
        const float d = std::max(std::abs(P.x), std::abs(P.z));
        if (d > 0.6f && d < 0.75f) nearBox += fast->rgba[p * 4 + 1], ++nNear;
        if (d > 3.f) far += fast->rgba[p * 4 + 1], ++nFar;
    });
    ASSERT_GT(nNear, 50u);
    ASSERT_GT(nFar, 50u);
    std::printf("courtyard, box on the ground, Lambert: fast vs reference mean %.2f%% (unshadowed %.2f%%); ground beside the "
                "box %.3f of far away\n",
                100 * shadowed.meanRel(), 100 * unshadowed.meanRel(), (nearBox / double(nNear)) / (far / double(nFar)));
    EXPECT_LT(shadowed.meanRel(), 0.05);
    EXPECT_GT(unshadowed.meanRel(), 2 * shadowed.meanRel());
    EXPECT_LT((nearBox / double(nNear)) / (far / double(nFar)), 0.85);
}

} // namespace

namespace {

// The shot's baked specular lobe (DeepBuffer::envLobe, format version 4) against the same shot
// without it (a version 3 shot: the order-3 occlusion, directionalVisibility): a Lambert shot
// renders the same either way (the lobe touches the specular term alone), and a glossy metal box
// on the ground is nearer the ray-traced reference with it.
TEST(EnvironmentLight, BakedLobeTouchesTheSpecularAloneAndBringsItNearerTheReference) {
    const std::string maps = DFB_SOURCE_DIR "/scenes/env";
    Light l = environment("env", "courtyard.exr");
    l.shadow = true;
    Rig rig;
    rig.lights = {l};
    for (const bool metal : {false, true}) {
        Shot s;
        ShotOptions opt;
        opt.boxMin = {-0.6f, 0.f, -0.6f};
        opt.boxMax = {0.6f, 0.8f, 0.6f};
        opt.metallic = metal ? 1.f : 0.f;
        opt.specularFactor = metal ? 1.f : 0.f;
        opt.roughness = metal ? 0.35f : 1.f;
        opt.envRays = 256;
        ASSERT_NO_FATAL_FAILURE(makeShot(s, opt));
        ASSERT_TRUE(s.g.hasEnvLobe());
        s.engine->setAssetDirectory(maps);
        DeepBuffer without = s.g;
        without.envLobe.clear();
        auto old = Engine::create(without, shadowCasters(s.scene));
        ASSERT_TRUE(old.ok()) << old.error().toString();
        old.value()->setAssetDirectory(maps);
        auto withLobe = s.engine->renderLightLinear(rig, "env");
        auto withoutLobe = old.value()->renderLightLinear(rig, "env");
        ASSERT_TRUE(withLobe.ok() && withoutLobe.ok());
        if (!metal) {
            double worst = 0;
            forEachSample(s.g, [&](size_t p, size_t) {
                for (int c = 0; c < 3; ++c)
                    worst = std::max(worst, double(std::abs(withLobe->rgba[p * 4 + size_t(c)] - withoutLobe->rgba[p * 4 + size_t(c)])));
            });
            std::printf("Lambert: the lobe changes nothing (largest difference %.2e)\n", worst);
            EXPECT_EQ(worst, 0.0);
            continue;
        }
        const float radius = 0.5f * glm::length(s.scene.bounds.max - s.scene.bounds.min);
        auto ref = renderEnvironmentReference(s.g, &s.rays, radius, l, maps, 512);
        ASSERT_TRUE(ref.ok()) << ref.error().toString();
        Errors lobe, order3;
        forEachSample(s.g, [&](size_t p, size_t) {
            lobe.add(withLobe->rgba[p * 4 + 1], ref->rgba[p * 4 + 1]);
            order3.add(withoutLobe->rgba[p * 4 + 1], ref->rgba[p * 4 + 1]);
        });
        std::printf("courtyard, metal of roughness 0.35, box on the ground: fast vs reference %.2f%% with the baked lobe, %.2f%% "
                    "with the order-3 occlusion\n",
                    100 * lobe.meanRel(), 100 * order3.meanRel());
        EXPECT_LT(lobe.meanRel(), order3.meanRel());
    }
}

} // namespace

namespace {

// `reference:NAME` of an environment light (dfb/server/Outputs.h): the ray-traced reference as
// the server serves it, refused without the scene's hierarchy.
TEST(EnvironmentLight, ReferenceIsAnOutput) {
    Shot s;
    ASSERT_NO_FATAL_FAILURE(makeShot(s, true));
    Rig rig;
    rig.lights = {environment("dome")};
    rig.lights[0].shadow = true;
    OutputRequest req;
    req.output = "reference:dome";
    req.format = "exr";
    auto refused = renderOutput(*s.engine, s.g, rig, req);
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.error().message.find("light 'dome': no reference here"), std::string::npos) << refused.error().message;
    auto out = renderOutput(*s.engine, s.g, rig, req, ReferenceScene{&s.rays, 6.f, "."});
    ASSERT_TRUE(out.ok()) << out.error().message;
    EXPECT_EQ(out->width, s.g.width);
    EXPECT_EQ(out->height, s.g.height);
    EXPECT_EQ(out->contentType, "image/x-exr");
}

} // namespace

namespace {

// A Lambert box on the ground (makeShot, 256 bake rays) under the shadowed environment light
// "env" of map `map` in `dir`: the engine's frame (st), then the light's image and the
// reference's (768 rays).
struct BoxUnderMap {
    Shot s;
    Rig rig;
    FrameStats st;
    ImageF fast, ref;
};

void boxUnderMap(BoxUnderMap& b, const fs::path& dir, const char* map) {
    ShotOptions opt;
    opt.specularFactor = 0.f;
    opt.roughness = 1.f;
    opt.envRays = 256;
    ASSERT_NO_FATAL_FAILURE(makeShot(b.s, opt));
    b.s.engine->setAssetDirectory(dir.string());
    Light l = environment("env", map);
    l.shadow = true;
    b.rig.lights = {l};
    ASSERT_TRUE(b.s.engine->render(b.rig, &b.st).ok());
    auto fast = b.s.engine->renderLightLinear(b.rig, "env");
    ASSERT_TRUE(fast.ok()) << fast.error().message;
    const float radius = 0.5f * glm::length(b.s.scene.bounds.max - b.s.scene.bounds.min);
    auto ref = renderEnvironmentReference(b.s.g, &b.s.rays, radius, l, dir.string(), 768);
    ASSERT_TRUE(ref.ok()) << ref.error().message;
    b.fast = std::move(fast.value());
    b.ref = std::move(ref.value());
}

// The engine's cube-map layout of the prefiltered map (prefilterEnvironment's cubeSize, read by
// relight_env.frag with a direction) holds what the lat-long layout holds, level by level: read
// bilinearly at random directions, the two agree to within 2 % of the map's range on a map with
// smooth gradients and a sharp-edged patch (level 0: where neither lies on the patch's edge).
TEST(EnvironmentLight, PrefilteredCubeMapAgreesWithTheLatLongLevels) {
    ImageF map{256, 128, std::vector<float>(256 * 128 * 4, 1.f)};
    for (int j = 0; j < map.height; ++j)
        for (int i = 0; i < map.width; ++i) {
            const glm::dvec3 d = lightmath::envDirection((i + 0.5) / map.width, (j + 0.5) / map.height);
            float* t = &map.rgba[(size_t(j) * size_t(map.width) + size_t(i)) * 4];
            t[0] = float(1.0 + d.y), t[1] = float(1.0 + 0.5 * d.x), t[2] = glm::dot(d, glm::normalize(glm::dvec3(1, 1, -1))) > 0.9 ? 4.f : 0.5f;
        }
    constexpr int LEVELS = 6, WIDTH = 512;
    const engine::EnvLevels ll = engine::prefilterEnvironment(map, LEVELS, WIDTH);
    const engine::EnvLevels cube = engine::prefilterEnvironment(map, LEVELS, WIDTH, WIDTH / 4);
    ASSERT_TRUE(cube.cube);
    ASSERT_EQ(cube.widths.size(), size_t(LEVELS));
    EXPECT_EQ(cube.widths[0], WIDTH / 4);
    EXPECT_EQ(cube.widths[LEVELS - 1], WIDTH / 4 >> (LEVELS - 1));
    auto latLong = [&](int k, const glm::dvec3& d) {
        const int w = ll.widths[size_t(k)], h = w / 2;
        const glm::dvec2 uv = lightmath::envLatLong(d);
        const double x = uv.x * w - 0.5, y = std::clamp(uv.y * h - 0.5, 0.0, h - 1.0);
        const int i = int(std::floor(x)), j = std::min(int(y), h - 2);
        const double fx = x - i, fy = y - j;
        auto at = [&](int a, int b) {
            a = ((a % w) + w) % w;
            const float* t = &ll.rgba[size_t(k)][(size_t(b) * size_t(w) + size_t(a)) * 4];
            return glm::dvec3(t[0], t[1], t[2]);
        };
        return (at(i, j) * (1 - fx) + at(i + 1, j) * fx) * (1 - fy) + (at(i, j + 1) * (1 - fx) + at(i + 1, j + 1) * fx) * fy;
    };
    auto fromCube = [&](int k, const glm::dvec3& d) {
        glm::dvec2 st;
        const int face = lightmath::cubeFace(d, st), n = cube.widths[size_t(k)];
        const double x = std::clamp(st.x * n - 0.5, 0.0, n - 1.0), y = std::clamp(st.y * n - 0.5, 0.0, n - 1.0);
        const int i = std::min(int(x), std::max(n - 2, 0)), j = std::min(int(y), std::max(n - 2, 0));
        const double fx = n > 1 ? x - i : 0, fy = n > 1 ? y - j : 0;
        auto at = [&](int a, int b) {
            const float* t = &cube.rgba[size_t(k)][((size_t(face) * size_t(n) + size_t(std::min(b, n - 1))) * size_t(n) +
                                                     size_t(std::min(a, n - 1))) * 4];
            return glm::dvec3(t[0], t[1], t[2]);
        };
        return (at(i, j) * (1 - fx) + at(i + 1, j) * fx) * (1 - fy) + (at(i, j + 1) * (1 - fx) + at(i + 1, j + 1) * fx) * fy;
    };
    std::mt19937 rng(11);
    std::normal_distribution<double> g;
    for (int k = 0; k < LEVELS - 1; ++k) { // the last level's faces are 4 texels: bilinear there is coarse in both layouts
        double worst = 0;
        int compared = 0;
        for (int n = 0; n < 2000; ++n) {
            const glm::dvec3 d = glm::normalize(glm::dvec3(g(rng), g(rng), g(rng)));
            if (k == 0 && std::abs(glm::dot(d, glm::normalize(glm::dvec3(1, 1, -1))) - 0.9) < 0.03) continue;
            worst = std::max(worst, glm::length(fromCube(k, d) - latLong(k, d)) / 4.0);
            ++compared;
        }
        std::printf("level %d: worst difference %.4f of the range over %d directions\n", k, worst, compared);
        EXPECT_LT(worst, 0.02) << "level " << k;
    }
}

// A map with a small, very bright sun: extractSun finds it (direction, irradiance), the engine
// shades it as a directional light with a sharp shadow map, and against the ray-traced
// reference the box's shadow is where the sun puts it; a rotation re-renders the sun's map.
TEST(EnvironmentLight, ASunIsExtractedAndShadowsSharply) {
    const fs::path dir = mapFolder();
    const glm::dvec3 toSun = glm::normalize(glm::dvec3(0.5, 0.6, 0.4));
    const double sunCos = std::cos(glm::radians(1.5)), sunRadiance = 4e4, sky = 0.5;
    const auto sunny = [&](const glm::dvec3& d) { return glm::vec3(float(glm::dot(d, toSun) > sunCos ? sunRadiance : sky)); };
    constexpr int W = 512, H = 256;
    ASSERT_NO_FATAL_FAILURE(writeMap(dir / "sunny.exr", W, H, sunny));
    auto map = readHdrImage((dir / "sunny.exr").string(), MAX_ENV_MAP_WIDTH, MAX_ENV_MAP_HEIGHT);
    ASSERT_TRUE(map.ok());
    // The sun's irradiance as the map holds it: (L - sky) x the solid angle of its texels.
    double want = 0;
    for (int j = 0; j < H; ++j)
        for (int i = 0; i < W; ++i)
            if (glm::dot(lightmath::envDirection((i + 0.5) / W, (j + 0.5) / H), toSun) > sunCos)
                want += (sunRadiance - sky) * lightmath::envTexelSolidAngle(j, W, H);
    ImageF rest = map.value();
    const engine::EnvSun sun = engine::extractSun(rest);
    ASSERT_TRUE(sun.found);
    const double angle = glm::degrees(std::acos(std::clamp(glm::dot(glm::dvec3(sun.direction), toSun), -1.0, 1.0)));
    std::printf("sun: %.3f degrees off, irradiance %.4g of %.4g\n", angle, double(sun.irradiance.y), want);
    EXPECT_LT(angle, 0.3);
    EXPECT_NEAR(sun.irradiance.y, want, 0.01 * want);
    float brightest = 0;
    for (size_t p = 0; p < rest.rgba.size(); p += 4) brightest = std::max(brightest, rest.rgba[p + 1]);
    EXPECT_LT(brightest, 1.f);

    BoxUnderMap b;
    ASSERT_NO_FATAL_FAILURE(boxUnderMap(b, dir, "sunny.exr"));
    EXPECT_EQ(b.st.shadowMapsRendered, 1); // the sun's
    Shot& s = b.s;
    const ImageF* fast = &b.fast;
    const ImageF* ref = &b.ref;
    // Lit by the sun or in the box's shadow, in both: the sun's share dominates.
    size_t agree = 0, ground = 0;
    Errors err;
    double meanFast = 0;
    forEachSample(s.g, [&](size_t p, size_t i) {
        err.add(fast->rgba[p * 4 + 1], ref->rgba[p * 4 + 1]);
        if (s.g.objectId[i] != 1) return;
        meanFast += fast->rgba[p * 4 + 1];
        ++ground;
    });
    meanFast /= double(ground);
    forEachSample(s.g, [&](size_t p, size_t i) {
        if (s.g.objectId[i] == 1) agree += (fast->rgba[p * 4 + 1] > 0.5 * meanFast) == (ref->rgba[p * 4 + 1] > 0.5 * meanFast);
    });
    std::printf("sunny map, box on the ground, Lambert: fast vs reference mean %.2f%%; lit/shadowed agree on %.2f%% of the ground\n",
                100 * err.meanRel(), 100.0 * double(agree) / double(ground));
    EXPECT_LT(err.meanRel(), 0.05);
    EXPECT_GT(double(agree) / double(ground), 0.99);
    b.rig.lights[0].envRotationDeg = {20.f, 0.f, 0.f};
    FrameStats st;
    ASSERT_TRUE(s.engine->render(b.rig, &st).ok());
    EXPECT_EQ(st.shadowMapsRendered, 1);
    EXPECT_EQ(st.lightsShaded, 1);
    // Turned back to 20 degrees after a dragged turn (preview: every second pixel into the
    // image's top-left quarter, the sun's map at preview size) or after a full-quality one, the
    // image is the one first shaded at 20 degrees, empty pixels included: its contribution is not
    // cleared between frames over the same footprint (LightShading::shadeInto), but is after a
    // preview.
    auto at20 = s.engine->renderLightLinear(b.rig, "env");
    ASSERT_TRUE(at20.ok());
    for (bool preview : {true, false}) {
        s.engine->setPreview(preview);
        b.rig.lights[0].envRotationDeg = {60.f, 0.f, 0.f};
        ASSERT_TRUE(s.engine->render(b.rig, &st).ok());
        s.engine->setPreview(false);
        b.rig.lights[0].envRotationDeg = {20.f, 0.f, 0.f};
        ASSERT_TRUE(s.engine->render(b.rig, &st).ok());
        auto again = s.engine->renderLightLinear(b.rig, "env");
        ASSERT_TRUE(again.ok());
        size_t differ = 0;
        for (size_t i = 0; i < again->rgba.size(); ++i)
            differ += std::abs(again->rgba[i] - at20->rgba[i]) > 1e-6f * std::max(1.f, std::abs(at20->rgba[i]));
        EXPECT_EQ(differ, 0u) << (preview ? "after a preview" : "after a full frame");
    }
}

} // namespace

namespace {

// The backdrop (a viewer's `background` view setting; docs/protocol.md "view"): where the shot
// covers nothing, the 8-bit beauty shows the environment along the camera ray, turned and scaled
// like the light; covered pixels are the beauty as before.
TEST(EnvironmentLight, TheBackdropShowsTheMapBehindTheScene) {
    const fs::path dir = mapFolder();
    // A smooth map (linear in the direction): bilinear lookup is exact up to the texel grid's
    // curvature.
    const auto f = [](const glm::dvec3& d) { return glm::vec3(0.5 + 0.5 * d.x, 0.5 + 0.5 * d.y, 0.5 + 0.5 * d.z); };
    ASSERT_NO_FATAL_FAILURE(writeMap(dir / "smooth.exr", 512, 256, f));
    Shot s;
    ASSERT_NO_FATAL_FAILURE(makeShot(s, true));
    Rig rig;
    rig.lights = {environment("dome", "smooth.exr")};
    rig.lights[0].envRotationDeg = {30.f, 10.f, -5.f};
    rig.lights[0].intensityCd = 0.5f;
    rig.lights[0].color = {1.f, 0.5f, 0.25f};
    auto back = environmentBackground(s.g, rig, dir.string());
    ASSERT_TRUE(back.ok()) << back.error().message;
    const glm::dmat4 fromNdc = glm::inverse(glm::dmat4(s.g.camera.worldToNDC));
    const glm::dmat3 R = lightmath::envRotation(rig.lights[0].envRotationDeg);
    size_t uncovered = 0, covered = 0;
    double worst = 0;
    for (int y = 0; y < s.g.height; ++y)
        for (int x = 0; x < s.g.width; ++x) {
            const float* px = &back->rgba[(size_t(y) * size_t(s.g.width) + size_t(x)) * 4];
            const float a = s.g.coverage(x, y);
            if (a >= 1.f) {
                EXPECT_EQ(px[0] + px[1] + px[2], 0.f) << x << ", " << y;
                ++covered;
                continue;
            }
            if (a > 0.f) continue; // edges: the uncovered share
            ++uncovered;
            // The camera ray, from the camera's position through the pixel centre's far point.
            const double nx = (x + 0.5) / s.g.width * 2 - 1, ny = 1 - (y + 0.5) / s.g.height * 2;
            const glm::dvec4 far = fromNdc * glm::dvec4(nx, ny, 1, 1);
            const glm::dvec3 ray = glm::normalize(glm::dvec3(far) / far.w - glm::dvec3(s.g.camera.position()));
            const glm::vec3 want = 0.5f * glm::vec3(1.f, 0.5f, 0.25f) * f(glm::transpose(R) * ray);
            for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(double(px[c]) - want[c]) / double(want[c]));
        }
    std::printf("backdrop: %zu uncovered pixels, worst relative error %.2g against the map along the camera ray\n", uncovered, worst);
    ASSERT_GT(uncovered, 1000u) << "the shot has sky above the ground";
    ASSERT_GT(covered, 1000u);
    EXPECT_LT(worst, 2e-3);

    // Through renderOutput: the PNG with the backdrop against the plain one, decoded.
    auto decode = [&](const EncodedImage& e, const char* name) {
        const fs::path p = dir / name;
        std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(e.bytes.data()), std::streamsize(e.bytes.size()));
        auto img = readLinearImage(p.string());
        EXPECT_TRUE(img.ok());
        return img.value();
    };
    s.engine->setAssetDirectory(dir.string());
    OutputRequest req;
    req.format = "png";
    auto plain = renderOutput(*s.engine, s.g, rig, req, ReferenceScene{nullptr, 6.f, dir.string()});
    req.background = true;
    auto withBack = renderOutput(*s.engine, s.g, rig, req, ReferenceScene{nullptr, 6.f, dir.string()});
    ASSERT_TRUE(plain.ok() && withBack.ok());
    const ImageF a = decode(plain.value(), "plain.png"), b = decode(withBack.value(), "back.png");
    double coveredDiff = 0, skyPlain = 0, skyBack = 0;
    for (int y = 0; y < s.g.height; ++y)
        for (int x = 0; x < s.g.width; ++x) {
            const size_t i = (size_t(y) * size_t(s.g.width) + size_t(x)) * 4;
            const float cov = s.g.coverage(x, y);
            if (cov >= 1.f) {
                for (int c = 0; c < 3; ++c) coveredDiff = std::max(coveredDiff, double(std::abs(a.rgba[i + c] - b.rgba[i + c])));
            } else if (cov <= 0.f) {
                skyPlain = std::max(skyPlain, double(a.rgba[i + 1]));
                skyBack += b.rgba[i + 1];
            }
        }
    skyBack /= double(uncovered);
    std::printf("backdrop PNG: covered pixels within %.3g (linear), sky %.3g without, mean green %.3g with\n", coveredDiff, skyPlain, skyBack);
    EXPECT_LT(coveredDiff, 0.01); // an 8-bit step near white (the GPU's and the CPU's view transform)
    EXPECT_EQ(skyPlain, 0.0);
    EXPECT_GT(skyBack, 0.05);
    fs::remove_all(dir);
}

// A map with a sun, a window (dimmer per texel than the sun and a lamp, but more light in all)
// and two lamps: extractSuns takes out the brightest three in order of their peaks, each with its
// direction and irradiance, and leaves the last lamp in the map (ENV_MAX_SUNS); the engine shades
// the three as directional lights with a shadow map each, and against the ray-traced reference
// the box's three shadows are where they belong.
TEST(EnvironmentLight, SeveralLightsAreExtractedEachWithItsShadow) {
    const fs::path dir = mapFolder();
    struct Spot {
        glm::dvec3 dir;
        double radiusDeg, radiance;
    };
    const double sky = 0.5;
    const Spot spots[4] = {{glm::normalize(glm::dvec3(0.5, 0.6, 0.4)), 1.0, 4e4},    // the sun
                           {glm::normalize(glm::dvec3(0.2, 0.45, -0.9)), 0.8, 8e3},  // a lamp
                           {glm::normalize(glm::dvec3(-0.6, 0.5, 0.3)), 3.0, 5e3},   // the window
                           {glm::normalize(glm::dvec3(-0.3, 0.8, -0.5)), 1.0, 3e3}}; // a lamp left in the map
    const auto radiance = [&](const glm::dvec3& d) {
        for (const Spot& sp : spots)
            if (glm::dot(d, sp.dir) > std::cos(glm::radians(sp.radiusDeg))) return glm::vec3(float(sp.radiance));
        return glm::vec3(float(sky));
    };
    constexpr int W = 1024, H = 512;
    ASSERT_NO_FATAL_FAILURE(writeMap(dir / "lamps.exr", W, H, radiance));
    auto map = readHdrImage((dir / "lamps.exr").string(), MAX_ENV_MAP_WIDTH, MAX_ENV_MAP_HEIGHT);
    ASSERT_TRUE(map.ok());
    ImageF rest = map.value();
    const std::vector<engine::EnvSun> suns = engine::extractSuns(rest);
    ASSERT_EQ(suns.size(), size_t(ENV_MAX_SUNS));
    ASSERT_EQ(ENV_MAX_SUNS, 3);
    const int order[3] = {0, 1, 2}; // by peak: the sun, the lamp, the window
    for (int k = 0; k < 3; ++k) {
        const Spot& sp = spots[order[k]];
        double want = 0;
        for (int j = 0; j < H; ++j)
            for (int i = 0; i < W; ++i)
                if (glm::dot(lightmath::envDirection((i + 0.5) / W, (j + 0.5) / H), sp.dir) > std::cos(glm::radians(sp.radiusDeg)))
                    want += (sp.radiance - sky) * lightmath::envTexelSolidAngle(j, W, H);
        const double angle = glm::degrees(std::acos(std::clamp(glm::dot(glm::dvec3(suns[size_t(k)].direction), sp.dir), -1.0, 1.0)));
        std::printf("light %d: %.3f degrees off, irradiance %.4g of %.4g\n", k, angle, double(suns[size_t(k)].irradiance.y), want);
        EXPECT_LT(angle, 0.3) << k;
        EXPECT_NEAR(suns[size_t(k)].irradiance.y, want, 0.01 * want) << k;
    }
    // The fourth stays: the brightest texel left is the last lamp's.
    float brightest = 0;
    for (size_t p = 0; p < rest.rgba.size(); p += 4) brightest = std::max(brightest, rest.rgba[p + 1]);
    EXPECT_FLOAT_EQ(brightest, float(spots[3].radiance));

    BoxUnderMap b;
    ASSERT_NO_FATAL_FAILURE(boxUnderMap(b, dir, "lamps.exr"));
    EXPECT_EQ(b.st.shadowMapsRendered, 3);
    Errors err;
    forEachSample(b.s.g, [&](size_t p, size_t) { err.add(b.fast.rgba[p * 4 + 1], b.ref.rgba[p * 4 + 1]); });
    std::printf("three lights and a lamp, box on the ground, Lambert: fast vs reference mean %.2f%%\n", 100 * err.meanRel());
    EXPECT_LT(err.meanRel(), 0.05);
}

} // namespace
