// The engine's caches are right: after a random sequence of 200 edits of every kind (rescales,
// re-shades, new shadow maps, lights switched on and off, BendyLight control points), the cached
// frame equals a from-scratch render of the final rig, and so do frames along the way.

#include <dfb/gbuffer/Baker.h>
#include <dfb/server/Engine.h>

#include "support/SchemaEdits.h"
#include "support/TabletopShot.h"

#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <filesystem>
#include <map>
#include <random>
#include <unistd.h>

using namespace dfb;

namespace {

// Largest difference relative to the image's mean value (per channel value).
double relativeDifference(const ImageF& a, const ImageF& b) {
    double worst = 0, mean = 0;
    for (size_t i = 0; i < a.rgba.size(); i += 4)
        for (int k = 0; k < 3; ++k) mean += a.rgba[i + size_t(k)];
    mean /= double(a.rgba.size() / 4 * 3);
    for (size_t i = 0; i < a.rgba.size(); i += 4)
        for (int k = 0; k < 3; ++k) {
            const double x = a.rgba[i + size_t(k)], y = b.rgba[i + size_t(k)];
            worst = std::max(worst, std::abs(x - y) / (std::abs(x) + mean));
        }
    return worst;
}

// A BendyLight named "bendy" made from the spot `base`: two segments, the last point moved sideways.
Light bentLight(const Light& base) {
    Light bendy = base;
    bendy.name = "bendy";
    makeStraightChain(bendy, 3.f, 2);
    bendy.controlPoints[3][2] += 0.6f;
    return bendy;
}

// A shadowed point light and a shadowed directional light made from `base`, so that a rig has
// every light type.
Light bulbLight(Light l, int mapSize) {
    l.name = "bulb";
    l.type = LightType::Point;
    l.position = {1.f, 1.5f, 1.f};
    l.intensityCd = 4.f;
    l.shadow = true;
    l.shadowMapSize = mapSize;
    l.exclude.clear();
    return l;
}
Light sunLight(Light l, int mapSize) {
    l.name = "sun";
    l.type = LightType::Directional;
    l.direction = {0.3f, -1.f, 0.2f};
    l.intensityCd = 2.f;
    l.shadow = true;
    l.shadowMapSize = mapSize;
    l.exclude.clear();
    return l;
}

// Values (per channel) lit in `want`, and values of `got` differing from it by more than 0.1%.
std::pair<size_t, size_t> litAndDiffering(const ImageF& got, const ImageF& want) {
    size_t lit = 0, off = 0;
    for (size_t i = 0; i < got.rgba.size(); i += 4)
        for (int k = 0; k < 3; ++k) {
            const float x = got.rgba[i + size_t(k)], y = want.rgba[i + size_t(k)];
            lit += y > 0.f;
            off += std::abs(x - y) > 1e-3f * std::max(std::abs(y), 1e-3f);
        }
    return {lit, off};
}

} // namespace

TEST(EngineCache, TwoHundredRandomEditsMatchAFromScratchRender) {
    auto tabletop = test::tabletopEngine(128, 72, 4); // deep: samples are shaded and averaged in every path
    ASSERT_TRUE(tabletop.ok()) << tabletop.error().toString();
    auto& [scene, shot, casters, cached] = tabletop.value();

    const Bounds& b = scene.bounds;
    Rig rig = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    Light bendy = rig.lights[0];
    bendy.name = "bendy";
    makeStraightChain(bendy, 6.f, 2);
    bendy.controlPoints[3] = {4.5f, 0.f, 1.2f};
    rig.lights.push_back(bendy);
    Light rim = rig.lights[1];
    rim.name = "rim";
    rim.position = {0.f, 3.f, -4.f};
    rim.direction = {0.f, -0.5f, 1.f};
    rim.shadow = true;
    rim.shadowMapSize = 512;
    rig.lights.push_back(rim);
    rig.lights.push_back(bulbLight(rig.lights[1], 256));

    std::mt19937 rng(12345);
    std::uniform_real_distribution<float> u(-1.f, 1.f);
    int checks = 0;
    double worst = 0;
    for (int e = 1; e <= 200; ++e) {
        Light& l = rig.lights[rng() % rig.lights.size()];
        switch (rng() % 14) {
        case 0: l.intensityCd = std::max(0.f, l.intensityCd * (1.f + 0.3f * u(rng))); break;
        case 1: l.color = {0.5f + 0.5f * std::abs(u(rng)), 0.5f + 0.5f * std::abs(u(rng)), 0.5f + 0.5f * std::abs(u(rng))}; break;
        case 2: l.coneAngleDeg = std::clamp(l.coneAngleDeg + 3.f * u(rng), 10.f, 70.f);
                l.penumbraDeg = std::min(l.penumbraDeg, l.coneAngleDeg); break;
        case 3: l.penumbraDeg = std::clamp(l.penumbraDeg + 2.f * u(rng), 0.f, l.coneAngleDeg); break;
        case 4: for (float& p : l.position) p += 0.2f * u(rng); break;
        case 5: {
            glm::vec3 d = glm::normalize(glm::vec3(l.direction[0], l.direction[1], l.direction[2]) + 0.1f * glm::vec3(u(rng), u(rng), u(rng)));
            l.direction = {d.x, d.y, d.z};
            break;
        }
        case 6: l.enabled = !l.enabled || (rng() % 3 != 0); break;
        case 7: l.shadow = !l.shadow; break;
        case 8: l.shadowBias = std::clamp(l.shadowBias + 0.5f * u(rng), 0.5f, 4.f); break;
        case 9:
            if (l.type == LightType::Bendy) l.controlPoints[2 + rng() % 2][2] += 0.2f * u(rng);
            else l.shadowMapSize = (rng() % 2) ? 512 : 1024;
            break;
        case 10: rig.exposureStops = 0.5f * u(rng); break;
        case 11: l.barnDoorsDeg[rng() % 4] = 5.f + 85.f * std::abs(u(rng)); break;
        case 12: l.shadowFilter = int(rng() % 3); break;
        case 13: cached->setPreview(rng() % 2 == 0); break; // a drag starts or stops
        }
        ++rig.version;
        ASSERT_TRUE(cached->render(rig).ok());
        if (e % 40 == 0) {
            cached->setPreview(false); // the comparison is with full quality
            auto a = cached->renderLinear(rig);
            auto fresh = Engine::create(shot, casters);
            ASSERT_TRUE(fresh.ok());
            auto c = fresh.value()->renderLinear(rig);
            ASSERT_TRUE(a.ok() && c.ok());
            const double d = relativeDifference(c.value(), a.value());
            if (std::getenv("DFB_CACHE_DEBUG")) {
                for (const Light& each : rig.lights) {
                    const Light& l2 = each;
                    auto la = cached->renderLightLinear(rig, l2.name);
                    auto lc = fresh.value()->renderLightLinear(rig, l2.name);
                    double ma = 0, mc = 0;
                    for (size_t i = 0; i < la->rgba.size(); i += 4) { ma += la->rgba[i]; mc += lc->rgba[i]; }
                    std::printf("edit %d light %s type %d enabled %d shadow %d: %.2e (means %.6f vs %.6f) I %.3f cone %.2f pen %.2f col %.3f\n", e, l2.name.c_str(), int(l2.type),
                                int(l2.enabled), int(l2.shadow), relativeDifference(lc.value(), la.value()), ma, mc, l2.intensityCd,
                                l2.coneAngleDeg, l2.penumbraDeg, l2.color[0]);
                }
            }
            worst = std::max(worst, d);
            ++checks;
        }
    }
    std::printf("%d comparisons over 200 random edits: cached vs from-scratch, worst difference %.2e relative\n", checks, worst);
    // Tolerance: contributions are stored as half floats; a rescaled one rounds differently from
    // one shaded at the new intensity (2^-11 relative), nothing else may differ.
    EXPECT_LT(worst, 2e-3);
    EXPECT_EQ(checks, 5);
}

// Writes a 32x32 RGB cookie: checks of `cell` pixels in two colours.
void writeCookie(const std::string& path, int cell) {
    std::vector<uint8_t> px(32 * 32 * 3);
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 32; ++x) {
            const bool on = ((x / cell) + (y / cell)) % 2 == 0;
            uint8_t* p = &px[size_t(y * 32 + x) * 3];
            p[0] = on ? 255 : 30, p[1] = on ? 200 : 60, p[2] = on ? 150 : 255;
        }
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out && out->open(path, OIIO::ImageSpec(32, 32, 3, OIIO::TypeDesc::UINT8)) &&
                out->write_image(OIIO::TypeDesc::UINT8, px.data()) && out->close())
        << path;
}

// Writes a 64x32 float lat-long sky: brighter towards the top, with a warm patch.
void writeSky(const std::string& path) {
    std::vector<float> px(64 * 32 * 3);
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 64; ++x) {
            float* p = &px[size_t(y * 64 + x) * 3];
            const bool patch = x > 40 && x < 46 && y > 8 && y < 13;
            p[0] = patch ? 8.f : 1.f - float(y) / 40.f, p[1] = patch ? 5.f : 1.1f - float(y) / 40.f, p[2] = 1.3f - float(y) / 40.f;
        }
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out && out->open(path, OIIO::ImageSpec(64, 32, 3, OIIO::TypeDesc::FLOAT)) &&
                out->write_image(OIIO::TypeDesc::FLOAT, px.data()) && out->close())
        << path;
}

// Issue 15: the cache keys are derived from the rig schema, so this test edits every row of the
// schema (through the protocol's own path edits, as a client would), in turn, on a random light
// the row applies to, and compares with a from-scratch render along the way. A new row is edited
// here without touching this file (tests/support/SchemaEdits.h makes the values).
TEST(EngineCache, EverySchemaPropertyEditedAtRandomMatchesAFromScratchRender) {
    auto tabletop = test::tabletopEngine(96, 54, 2);
    ASSERT_TRUE(tabletop.ok()) << tabletop.error().toString();
    auto& [scene, shot, casters, cached] = tabletop.value();
    const auto assets = std::filesystem::temp_directory_path() / ("dfb_schema_cache_" + std::to_string(::getpid()));
    std::filesystem::create_directories(assets);
    writeCookie((assets / "checks.png").string(), 4);
    writeCookie((assets / "coarse.png").string(), 16);
    writeSky((assets / "sky.exr").string());
    cached->setAssetDirectory(assets.string());

    const Bounds& b = scene.bounds;
    Rig rig = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    Light bendy = bentLight(rig.lights[0]);
    rig.lights.push_back(bendy);
    rig.lights.push_back(bulbLight(rig.lights[1], 256));
    rig.lights.push_back(sunLight(rig.lights[1], 256));
    Light panel = rig.lights[1];
    panel.name = "panel";
    panel.type = LightType::Area;
    panel.areaSize = {0.3f, 0.2f};
    panel.shadowGrid = {2, 2};
    rig.lights.push_back(panel);
    Light bent = panel;
    bent.name = "bent";
    bent.type = LightType::BentArea;
    makeStraightCorners(bent, 1.f);
    bent.cornerPoints[1][2] += 0.2f; // corner 0 bends a little
    rig.lights.push_back(bent);
    Light dome;
    dome.name = "dome";
    dome.type = LightType::Environment;
    dome.intensityCd = 0.3f;
    dome.envMap = "sky.exr";
    rig.lights.push_back(dome);
    for (Light& l : rig.lights) l.shadowMapSize = std::min(l.shadowMapSize, 512);

    test::SchemaEditOptions opt;
    opt.objectCount = uint32_t(shot.objectNames.size());
    opt.cookies = {"", "checks.png", "coarse.png"};
    opt.envMaps = {"", "sky.exr"};
    // Seed 2024 left point lights 3 edits after the `shading` row joined the schema (the sequence
    // shifts with the rows); with the environment light's rows 2025 edited one type 5 times, 2026
    // covers every type more than 5 times.
    std::mt19937 rng(2026);
    std::map<std::string, int> edited; // schema row -> edits applied
    std::map<LightType, int> byType;
    const auto& rows = protocol::lightProperties();
    int checks = 0, edits = 0;
    double worst = 0;
    for (int round = 0; edits < 420; ++round) {
        const protocol::Property& row = rows[size_t(round) % rows.size()];
        std::vector<Light*> candidates;
        for (Light& l : rig.lights)
            if (row.appliesTo & (1u << unsigned(l.type))) candidates.push_back(&l);
        if (candidates.empty()) continue;
        Light& l = *candidates[rng() % candidates.size()];
        auto edit = test::randomEdit(row, l, rng, opt);
        if (!edit) continue;
        const LightType type = l.type;
        const std::string path = l.name + "." + edit->first;
        auto s = protocol::applyChange(rig, {path, edit->second});
        ASSERT_TRUE(s.ok()) << path << " = " << edit->second.dump() << ": " << s.error().toString();
        ++edited[row.path];
        ++byType[type];
        ++edits;
        ++rig.version;
        if (rng() % 8 == 0) cached->setPreview(rng() % 2 == 0); // a drag starts or stops
        ASSERT_TRUE(cached->render(rig).ok()) << "after " << path;
        if (edits % 30 == 0) {
            cached->setPreview(false); // the comparison is with full quality
            auto a = cached->renderLinear(rig);
            auto fresh = Engine::create(shot, casters);
            ASSERT_TRUE(fresh.ok());
            fresh.value()->setAssetDirectory(assets.string());
            auto c = fresh.value()->renderLinear(rig);
            ASSERT_TRUE(a.ok() && c.ok());
            const double d = relativeDifference(c.value(), a.value());
            EXPECT_LT(d, 2e-3) << "after edit " << edits << " (" << path << ")";
            if (d >= 2e-3) { // which light differs, and what it is
                for (const Light& each : rig.lights) {
                    if (!each.enabled) continue;
                    auto la = cached->renderLightLinear(rig, each.name), lc = fresh.value()->renderLightLinear(rig, each.name);
                    if (la.ok() && lc.ok() && relativeDifference(lc.value(), la.value()) >= 2e-3) {
                        ADD_FAILURE() << "light " << each.name << " differs by " << relativeDifference(lc.value(), la.value())
                                      << ": " << protocol::toJson(each).dump();
                    }
                }
            }
            worst = std::max(worst, d);
            ++checks;
        }
    }
    std::printf("%d edits of %zu schema rows, %d comparisons: worst difference %.2e relative\n", edits, edited.size(), checks, worst);
    for (const protocol::Property& row : rows) {
        const bool editable = !row.readOnly && row.type != protocol::PropType::Keys && std::string(row.path) != "name";
        if (editable) {
            EXPECT_GT(edited[row.path], 0) << "schema row '" << row.path << "' was never edited";
        }
    }
    // Every type edited (types change at random: the counts vary with the sequence).
    for (LightType t : {LightType::Spot, LightType::Point, LightType::Bendy, LightType::Directional, LightType::Area, LightType::BentArea,
                        LightType::Environment})
        EXPECT_GT(byType[t], 5) << "light type " << protocol::lightTypeName(t);
    EXPECT_EQ(checks, 14);
    std::filesystem::remove_all(assets);
}

TEST(LightLinking, ExcludedObjectsAreUnlitByThatLightAndEverythingElseIsUnchanged) {
    auto tabletop = test::tabletopEngine(160, 90);
    ASSERT_TRUE(tabletop.ok()) << tabletop.error().toString();
    const DeepBuffer& shot = tabletop->shot;
    Engine& engine = *tabletop->engine;
    const Bounds& b = tabletop->scene.bounds;
    Rig rig = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    uint32_t bunny = 0, table = 0;
    for (size_t i = 0; i < shot.objectNames.size(); ++i) {
        if (shot.objectNames[i] == "bunny") bunny = uint32_t(i + 1);
        if (shot.objectNames[i] == "table") table = uint32_t(i + 1);
    }
    ASSERT_NE(bunny, 0u);
    auto before = engine.renderLightLinear(rig, "key");
    ASSERT_TRUE(before.ok());
    rig.lights[0].exclude = {bunny};
    auto excluded = engine.renderLightLinear(rig, "key");
    rig.lights[0].exclude.clear();
    rig.lights[0].include = {table};
    auto included = engine.renderLightLinear(rig, "key");
    ASSERT_TRUE(excluded.ok() && included.ok());
    size_t bunnyLitBefore = 0, bunnyLitAfter = 0, otherChanged = 0, notTableLit = 0;
    for (size_t p = 0; p < shot.pixelCount(); ++p) {
        const float a = before->rgba[p * 4 + 1], e = excluded->rgba[p * 4 + 1], in = included->rgba[p * 4 + 1];
        if (shot.objectId[p] == bunny) {
            bunnyLitBefore += a > 0.f;
            bunnyLitAfter += e > 0.f;
        } else if (e != a) {
            ++otherChanged;
        }
        if (shot.objectId[p] != table) notTableLit += in > 0.f;
        else if (in != a) ++otherChanged;
    }
    std::printf("bunny pixels lit by the key: %zu, with the bunny excluded: %zu\n", bunnyLitBefore, bunnyLitAfter);
    EXPECT_GT(bunnyLitBefore, 200u);
    EXPECT_EQ(bunnyLitAfter, 0u);
    EXPECT_EQ(otherChanged, 0u); // linking is shading only: the table still receives the bunny's shadow
    EXPECT_EQ(notTableLit, 0u);
}

// The specialised shader variants and the footprint pre-pass (LightShading::shade) compute what the
// generic shaders compute: each light alone and the sum, for spots with barn doors, a wide
// shadow filter and light linking, a shadowed point light, a directional light, BendyLights
// of two and three segments (both light-direction models) and environment lights whose maps'
// suns are shaded in their own pass (one sun: sunrise.exr; three: interior.exr; ENV_SUNS against
// the block's count), with the baked transfer and horizon, on a flat and on a deep shot.
TEST(EngineSpecialisation, VariantsAndFootprintMatchTheGenericShaders) {
    auto scene = loadScene(DFB_SOURCE_DIR "/scenes/tabletop.glb");
    ASSERT_TRUE(scene.ok()) << scene.error().toString();
    const ShadowGeometry casters = shadowCasters(scene.value());
    const Bounds& b = scene->bounds;
    Rig rig = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    rig.lights[0].barnDoorsDeg = {20.f, 90.f, 15.f, 90.f};
    rig.lights[0].shadowFilter = 2;
    rig.lights[1].exclude = {2};
    Light bendy = rig.lights[0];
    bendy.name = "bendy";
    bendy.barnDoorsDeg = {90.f, 90.f, 90.f, 90.f};
    bendy.shadowFilter = 1;
    makeStraightChain(bendy, 6.f, 2);
    bendy.controlPoints[3] = {4.5f, 0.f, 1.2f};
    rig.lights.push_back(bendy);
    Light bendy3 = bendy;
    bendy3.name = "bendy3";
    makeStraightChain(bendy3, 5.f, 3);
    bendy3.controlPoints[2][0] += 0.8f;
    bendy3.controlPoints[5][2] -= 0.7f;
    bendy3.exactDirection = true;
    rig.lights.push_back(bendy3);
    rig.lights.push_back(bulbLight(rig.lights[1], 256));
    rig.lights.push_back(sunLight(rig.lights[1], 512));
    for (const char* map : {"sunrise.exr", "interior.exr"}) {
        Light env;
        env.name = std::string("env-") + map;
        env.type = LightType::Environment;
        env.envMap = map;
        env.envRotationDeg = {35.f, 0.f, 0.f};
        env.intensityCd = 0.5f;
        rig.lights.push_back(env);
    }

    for (int samples : {1, 4}) {
        SCOPED_TRACE(std::to_string(samples) + " samples per pixel");
        BakeOptions o;
        o.width = 160;
        o.height = 90;
        o.samples = samples;
        o.envRays = 64;
        auto shot = bake(scene.value(), o);
        ASSERT_TRUE(shot.ok()) << shot.error().toString();
        auto special = Engine::create(shot.value(), casters);
        setenv("DFB_GENERIC_SHADERS", "1", 1);
        auto generic = Engine::create(shot.value(), casters);
        unsetenv("DFB_GENERIC_SHADERS");
        ASSERT_TRUE(special.ok() && generic.ok());
        special.value()->setAssetDirectory(DFB_SOURCE_DIR "/scenes/env");
        generic.value()->setAssetDirectory(DFB_SOURCE_DIR "/scenes/env");
        for (const Light& l : rig.lights) {
            auto a = special.value()->renderLightLinear(rig, l.name);
            auto g = generic.value()->renderLightLinear(rig, l.name);
            ASSERT_TRUE(a.ok() && g.ok());
            const auto [lit, off] = litAndDiffering(a.value(), g.value());
            const double d = relativeDifference(g.value(), a.value());
            std::printf("%d spp, light %-7s: %zu lit values, %zu differ by more than 0.1%%, worst %.2e relative\n", samples,
                        l.name.c_str(), lit, off, d);
            EXPECT_GT(lit, 100u) << l.name;
            // Arithmetic in another order; BendyLight shadow maps from deformation code compiled
            // with another number of segments: a few values right at shadow edges may move.
            EXPECT_LE(double(off), 0.002 * double(lit)) << l.name;
        }
        auto a = special.value()->renderLinear(rig);
        auto g = generic.value()->renderLinear(rig);
        ASSERT_TRUE(a.ok() && g.ok());
        EXPECT_LT(relativeDifference(g.value(), a.value()), 2e-2);
    }
}

// Open planar casters (the table) are left out of the shadow maps of lights on the receivers'
// side, and meshes outside a map's frustum (a point light's cube faces) are not drawn into it:
// every light's image is the same as with everything drawn.
TEST(EngineShadows, PlanarCastersLeftOutChangeNoImage) {
    auto tabletop = test::bakeTabletop(160, 90);
    ASSERT_TRUE(tabletop.ok()) << tabletop.error().toString();
    const DeepBuffer& shot = tabletop->shot;
    const ShadowGeometry casters = shadowCasters(tabletop->scene);
    ASSERT_EQ(casters.planes.size(), 1u); // the table
    EXPECT_LT(casters.planarIndexStart, casters.indices.size());
    ShadowGeometry allDrawn = casters;
    allDrawn.planarIndexStart = allDrawn.indices.size();
    allDrawn.planes.clear();
    allDrawn.parts.clear(); // and no mesh culled against a map's frustum (a cube face's)
    // Runs of at most 2048 triangles per mesh: bunny 35, vases 6 + 6, bowl 3, table 3.
    ASSERT_EQ(casters.parts.size(), 53u);
    const Bounds& b = tabletop->scene.bounds;
    Rig rig = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    Light bendy = bentLight(rig.lights[0]);
    rig.lights.push_back(bendy);
    // dfb-bench's BendyLight: its tubes reach into the table, and their flow lines descend to it.
    const float size = glm::length(b.max - b.min);
    bendy.name = "reaching";
    makeStraightChain(bendy, 0.6f * size, 2);
    bendy.controlPoints[2][2] += 0.08f * size;
    bendy.controlPoints[3][2] += 0.2f * size;
    rig.lights.push_back(bendy);
    rig.lights.push_back(bulbLight(rig.lights[1], 512));
    rig.lights.push_back(sunLight(rig.lights[1], 1024));
    rig.lights[1].shadow = true;
    auto fewer = Engine::create(shot, casters);
    auto all = Engine::create(shot, allDrawn);
    auto counted = Engine::create(shot, casters);
    ASSERT_TRUE(fewer.ok() && all.ok() && counted.ok());
    for (const Light& l : rig.lights) {
        // The table is left out of every one of these lights' maps (each light is enabled once,
        // so its map is rendered then).
        Rig alone = rig;
        for (Light& other : alone.lights) other.enabled = other.name == l.name;
        FrameStats st;
        ASSERT_TRUE(counted.value()->render(alone, &st).ok());
        EXPECT_EQ(st.shadowMapsRendered, 1) << l.name;
        EXPECT_EQ(size_t(st.shadowCasterTriangles), casters.planarIndexStart / 3) << l.name;
        auto a = fewer.value()->renderLightLinear(rig, l.name);
        auto g = all.value()->renderLightLinear(rig, l.name);
        ASSERT_TRUE(a.ok() && g.ok());
        const auto [lit, off] = litAndDiffering(a.value(), g.value());
        std::printf("light %-9s: %zu lit values, %zu differ by more than 0.1%% without the table in its map\n", l.name.c_str(), lit, off);
        EXPECT_GT(lit, 100u) << l.name;
        EXPECT_LE(double(off), 0.002 * double(lit)) << l.name;
    }
}

// A deep shot whose every pixel holds its flat sample twice, at half coverage each, renders as the
// flat shot: the deep paths (relight passes once per sample over the sample textures, then summed
// per pixel through the pixel -> samples table; sampleTexel's power-of-two row layout at a width
// that is not one) address the right samples.
TEST(EngineDeep, EachSampleSplitInTwoRendersAsTheFlatShot) {
    auto tabletop = test::bakeTabletop(150, 84); // sample textures 256 wide
    ASSERT_TRUE(tabletop.ok()) << tabletop.error().toString();
    const DeepBuffer& f = tabletop->shot;
    ASSERT_TRUE(f.isFlat());
    DeepBuffer d = f;
    // Both halves sit at the pixel centre: this is no 2-sample bake, whose samples the edge taps
    // would spread over the pixel (docs/lighting.md, "Edges inside a pixel"), so it claims one.
    d.samplesPerPixel = 1;
    d.allocateSamples(f.width, f.height, std::vector<uint32_t>(f.pixelCount(), 2));
    auto split = [&](std::vector<float>& to, const std::vector<float>& from, size_t n) {
        for (size_t p = 0; p < f.pixelCount(); ++p)
            for (size_t s = 0; s < 2; ++s) std::copy_n(from.begin() + long(p * n), n, to.begin() + long((2 * p + s) * n));
    };
    split(d.P, f.P, 3), split(d.N, f.N, 3), split(d.Ng, f.Ng, 3), split(d.T, f.T, 4), split(d.Z, f.Z, 1);
    split(d.albedo, f.albedo, 3), split(d.brdf, f.brdf, 4), split(d.sheen, f.sheen, 4), split(d.coat, f.coat, 2);
    split(d.emission, f.emission, 3), split(d.A, f.A, 1);
    if (f.hasEnvTransfer()) { // allocateSamples left the optional layer empty
        d.envTransfer.resize(f.envTransfer.size() * 2);
        split(d.envTransfer, f.envTransfer, ENV_TRANSFER_COEFFICIENTS);
        d.envRays = f.envRays;
    }
    if (f.hasHorizon()) {
        d.horizon.resize(f.horizon.size() * 2);
        split(d.horizon, f.horizon, HORIZON_AZIMUTHS);
        d.horizonRadius = f.horizonRadius;
    }
    for (float& a : d.A) a *= 0.5f;
    for (size_t p = 0; p < f.pixelCount(); ++p) {
        d.objectId[2 * p] = d.objectId[2 * p + 1] = f.objectId[p];
        d.materialId[2 * p] = d.materialId[2 * p + 1] = f.materialId[p];
    }
    ASSERT_FALSE(d.isFlat());
    const ShadowGeometry casters = shadowCasters(tabletop->scene);
    auto flatEngine = Engine::create(f, casters);
    auto deepEngine = Engine::create(d, casters);
    ASSERT_TRUE(flatEngine.ok() && deepEngine.ok());
    const Bounds& b = tabletop->scene.bounds;
    Rig rig = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    rig.lights.push_back(bentLight(rig.lights[0]));
    rig.lights.push_back(bulbLight(rig.lights[1], 256));
    auto a = flatEngine.value()->renderLinear(rig);
    auto g = deepEngine.value()->renderLinear(rig);
    ASSERT_TRUE(a.ok() && g.ok());
    const double diff = relativeDifference(g.value(), a.value());
    std::printf("deep (2 half samples per pixel) vs flat: relative difference %.2e\n", diff);
    EXPECT_LT(diff, 1e-5);
    // Each light's shadow mask (the relight passes' other output: r = coverage-weighted visibility,
    // g = coverage, summed per pixel the same way).
    for (const Light& l : rig.lights) {
        auto ma = flatEngine.value()->renderShadowMask(rig, l.name);
        auto mg = deepEngine.value()->renderShadowMask(rig, l.name);
        ASSERT_TRUE(ma.ok() && mg.ok()) << l.name;
        double worstMask = 0;
        for (size_t i = 0; i < ma->rgba.size(); ++i) {
            if (i % 4 != 3) worstMask = std::max(worstMask, double(std::abs(ma->rgba[i] - mg->rgba[i]))); // r, g (alpha unused)
        }
        EXPECT_LT(worstMask, 1e-5) << l.name;
    }
    // The 8-bit frame too (the composite reads the contributions by pixel).
    auto a8 = flatEngine.value()->render(rig);
    auto g8 = deepEngine.value()->render(rig);
    ASSERT_TRUE(a8.ok() && g8.ok());
    int worst = 0;
    for (size_t i = 0; i < a8->rgba.size(); ++i) worst = std::max(worst, std::abs(int(a8->rgba[i]) - int(g8->rgba[i])));
    EXPECT_LE(worst, 1);
}
