// dfb-area-bench: area lights (issue 18 points 4 and 8). For a uniform disk, a uniform rectangle, a
// checkerboard and two textured patterns (a four-pane window and fluorescent tubes, drawn by this
// program into a temporary asset folder), each near (0.5 light sizes from the scene's centre) and
// far (5 sizes), the error of one-shot against the stratified reference (Engine::renderAreaReference,
// 32 x 32 cells): mean and 95th percentile of the per-pixel relative error over the pixels the
// reference lights (above 1 % of its 99th percentile), and the aggregate mean |one-shot - reference|
// / mean reference; for the uniform disk and rectangle the same for linearly transformed cosines
// (shading "ltc"; Heitz et al. 2016, 2017) beside one-shot's; the time of an edit of each mode and
// of the reference; the pattern tables' build
// time and memory and the alpha/beta fits' time. Then edit -> frame for an area light in the
// default rig: move with 1x1, 2x2, 4x4 and 8x8 shadow grids (full quality, and preview frames as
// during a drag), pattern change; a bent area light's corner control-point edit with 2x2 and 4x4
// interior lights (full quality and preview). A benchmark prints numbers; nothing here passes or fails.
//
//   dfb-area-bench SHOT.exr [--scene SCENE] [--edits N] [--cells G]

#include <dfb/core/Version.h>
#include <dfb/core/Stats.h>
#include <dfb/protocol/Schema.h>
#include <dfb/server/AreaPattern.h>
#include <dfb/server/Engine.h>
#include <dfb/server/ImageCodec.h>

#include "BenchShot.h"

#include <dfb/core/CommandLine.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>

using namespace dfb;
using Clock = std::chrono::steady_clock;

namespace {

double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

double mean(const std::vector<double>& v) {
    double s = 0.0;
    for (double x : v) s += x;
    return v.empty() ? 0.0 : s / double(v.size());
}

// A 256 x 256 pattern image written as PNG into `dir`.
bool writePattern(const std::filesystem::path& dir, const char* name, const std::function<float(float, float)>& value) {
    Image8 img;
    img.width = img.height = 256;
    img.rgba.resize(256 * 256 * 4, 255);
    for (int y = 0; y < 256; ++y)
        for (int x = 0; x < 256; ++x) {
            const float v = std::clamp(value((x + 0.5f) / 256.f, (y + 0.5f) / 256.f), 0.f, 1.f);
            const uint8_t b = uint8_t(std::lround(255.f * v));
            for (int c = 0; c < 3; ++c) img.rgba[size_t(y * 256 + x) * 4 + size_t(c)] = b;
        }
    auto png = encodePng(img);
    if (!png) return false;
    std::ofstream f(dir / name, std::ios::binary);
    f.write(reinterpret_cast<const char*>(png->data()), std::streamsize(png->size()));
    return bool(f);
}

struct Case {
    const char* name;
    AreaShape shape;
    const char* pattern;
};

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"dfb-area-bench: one-shot area lights against the stratified reference, and edit -> frame times"};
    app.set_version_flag("--version", dfb::versionText("dfb-area-bench"));
    std::string shotPath, scenePath;
    int edits = 10, cells = 32;
    app.add_option("shot", shotPath, "deep framebuffer EXR")->required();
    app.add_option("--scene", scenePath, "shadow casters (default: the shot's source scene)");
    app.add_option("--edits", edits, "timed edits per row")->check(CLI::Range(1, 1000));
    bool skipErrors = false;
    int mapSize = protocol::AREA_DEFAULT_MAP_SIZE, filter = -1;
    app.add_option("--map-size", mapSize, "each shadow map's side (shadowMapSize)")->check(CLI::IsMember({64, 128, 256, 512, 1024, 2048}));
    app.add_option("--filter", filter, "shadowFilter (default: the light's default)")->check(CLI::Range(0, 4));
    app.add_flag("--no-errors", skipErrors, "only the edit -> frame times");
    bool uniformOnly = false;
    app.add_flag("--uniform", uniformOnly, "errors of the uniform disk and rectangle only (one-shot and LTC)");
    app.add_option("--cells", cells, "the reference's cells per side")->check(CLI::Range(1, MAX_AREA_REFERENCE_CELLS));
    if (const int rc = dfb::parseCommandLine(app, argc, argv, "dfb-area-bench"); rc >= 0) return rc;
    keepFreedMemoryForFrames();

    bench::BenchShot opened;
    if (int rc = bench::openBenchShot("dfb-area-bench", shotPath, scenePath, opened)) return rc;
    Engine& engine = *opened.engine;
    const std::filesystem::path assets = std::filesystem::temp_directory_path() / "dfb-area-bench";
    std::filesystem::create_directories(assets);
    const bool written =
        writePattern(assets, "checker.png", [](float u, float v) { return (int(u * 8) + int(v * 8)) % 2 ? 0.f : 1.f; }) &&
        writePattern(assets, "window.png",
                     [](float u, float v) {
                         const bool mullion = std::abs(u - 0.5f) < 0.04f || std::abs(v - 0.5f) < 0.04f || u < 0.04f || u > 0.96f ||
                                              v < 0.04f || v > 0.96f;
                         return mullion ? 0.05f : 0.6f + 0.4f * v; // brighter towards the top (the sky)
                     }) &&
        writePattern(assets, "tubes.png", [](float u, float) {
            const float d = std::abs(std::fmod(u * 4.f, 1.f) - 0.5f); // four tubes across the width
            return std::exp(-d * d / 0.01f);
        });
    if (!written) {
        std::cerr << "dfb-area-bench: cannot write the patterns into " << assets << "\n";
        return 2;
    }
    engine.setAssetDirectory(assets.string());

    const Bounds& b = opened.scene.bounds;
    const Rig base = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    const Light& key = base.lights[0];
    const glm::vec3 centre = b.center();
    const glm::vec3 dir = glm::normalize(glm::vec3(key.direction[0], key.direction[1], key.direction[2]));
    const float size = 0.25f * glm::length(b.max - b.min);
    auto areaLight = [&](const Case& c, float distance) {
        Light l;
        l.name = "panel";
        l.type = LightType::Area;
        l.areaShape = c.shape;
        l.areaSize = {size, c.shape == AreaShape::Disk ? size : 0.6f * size};
        l.pattern = c.pattern;
        l.areaShading = AreaShading::OneShot; // the error table measures each mode by name
        const glm::vec3 p = centre - dir * distance;
        l.position = {p.x, p.y, p.z};
        l.direction = key.direction;
        l.intensityCd = 1.f;
        l.shadowMapSize = mapSize;
        l.shadowFilter = filter >= 0 ? filter : 0; // an area light's default (Schema.cpp setType)
        double fitMs = 0.0;
        auto ab = fitAreaAlphaBeta(l, assets.string(), &fitMs);
        if (ab) l.alphaBeta = ab.value();
        return std::make_pair(l, fitMs);
    };

    std::printf("device:   %s\n", engine.deviceDescription().c_str());
    std::printf("shot:     %s, %dx%d; light size %.3f (a quarter of the scene's diagonal), aimed as the default key\n",
                shotPath.c_str(), opened.shot.width, opened.shot.height, size);
    std::printf("error:    one-shot vs the reference (%d x %d cells), the light alone, shadows on (the same in both)\n\n", cells, cells);
    std::printf("%-18s %-5s %6s %6s | %-6s %9s %9s %9s | %10s %10s | %8s %8s %8s\n", "pattern", "dist", "alpha", "beta", "mode",
                "mean rel", "p95 rel", "aggregate", "per edit", "reference", "table", "KiB", "fit");
    const Case cases[] = {{"uniform disk", AreaShape::Disk, ""},
                          {"uniform rectangle", AreaShape::Rect, ""},
                          {"checkerboard", AreaShape::Rect, "checker.png"},
                          {"window (4 panes)", AreaShape::Rect, "window.png"},
                          {"tubes (4)", AreaShape::Rect, "tubes.png"}};
    for (const Case& c : cases) {
        if (skipErrors) break;
        if (uniformOnly && c.pattern[0] != '\0') continue;
        for (float d : {0.5f, 5.f}) {
            auto [light, fitMs] = areaLight(c, d * size);
            Rig rig;
            rig.lights = {light};
            auto table = areaPatternTable(light, assets.string());
            if (!table) {
                std::cerr << "dfb-area-bench: " << table.error().toString() << "\n";
                return 3;
            }
            if (!engine.render(rig)) return 3; // shadow maps and caches, outside the timing
            const auto t1 = Clock::now();
            auto ref = engine.renderAreaReference(rig, "panel", cells);
            const double refMs = msSince(t1);
            if (!ref) {
                std::cerr << "dfb-area-bench: " << ref.error().toString() << "\n";
                return 3;
            }
            std::vector<double> lum;
            for (size_t i = 0; i < ref->rgba.size(); i += 4) lum.push_back(ref->rgba[i] + ref->rgba[i + 1] + ref->rgba[i + 2]);
            const double floor = 0.01 * percentile(lum, 99);
            const lightmath::PatternTable& t = table.value()->table;
            // One-shot for every case; LTC for the uniform ones (with a pattern it would shade its mean).
            for (AreaShading mode : {AreaShading::OneShot, AreaShading::Ltc}) {
                if (mode == AreaShading::Ltc && c.pattern[0] != '\0') continue;
                rig.lights[0] = light; // where the reference was rendered
                rig.lights[0].areaShading = mode;
                std::vector<double> editMs;
                ImageF got;
                for (int i = 0; i < edits; ++i) {
                    // A move (maps and shading), ending where it started: the last image is compared.
                    rig.lights[0].position[0] = light.position[0] + (i % 2 || i + 1 == edits ? 0.f : 1e-3f * size);
                    const auto t0 = Clock::now();
                    auto img = engine.renderLightLinear(rig, "panel");
                    if (!img) return 3;
                    editMs.push_back(msSince(t0));
                    if (i + 1 == edits) got = std::move(img.value());
                }
                std::vector<double> rel;
                double sumAbs = 0.0, sumRef = 0.0;
                for (size_t i = 0; i < ref->rgba.size(); i += 4) {
                    const double r = ref->rgba[i] + ref->rgba[i + 1] + ref->rgba[i + 2], o = got.rgba[i] + got.rgba[i + 1] + got.rgba[i + 2];
                    sumAbs += std::abs(o - r);
                    sumRef += r;
                    if (r > floor && floor > 0) rel.push_back(std::abs(o - r) / r);
                }
                std::printf("%-18s %4.1fx %6.3f %6.3f | %-6s %8.1f%% %8.1f%% %8.1f%% | %8.1fms %8.0fms | %6.2fms %8.0f %6.0fms\n", c.name, d,
                            light.alphaBeta[0], light.alphaBeta[1], mode == AreaShading::Ltc ? "LTC" : "1-shot", 100 * mean(rel),
                            100 * percentile(rel, 95), 100 * sumAbs / std::max(sumRef, 1e-30), percentile(editMs, 50), refMs,
                            table.value()->buildMs, double(t.w + 1) * double(t.h + 1) * 16.0 / 1024.0, fitMs);
            }
        }
    }

    // Edit -> frame in the default rig (its key and fill cached) plus the area light.
    if (skipErrors) std::printf("(errors skipped)\n");
    std::printf("\nedit -> frame, the default rig plus the area light (1x from the centre), %d edits each, median / p90 / max:\n", edits);
    auto timeEdits = [&](const char* what, Rig rig, bool preview, const std::function<void(Light&, int)>& edit) {
        engine.setPreview(false);
        if (!engine.render(rig)) return false;
        engine.setPreview(preview);
        std::vector<double> ms, shadowMs, shadeMs;
        long triangles = 0;
        for (int i = 0; i < edits; ++i) {
            edit(rig.lights.back(), i);
            ++rig.version;
            const auto t0 = Clock::now();
            FrameStats st;
            auto img = engine.render(rig, &st);
            if (!img) return false;
            ms.push_back(msSince(t0));
            shadowMs.push_back(st.shadowMs);
            shadeMs.push_back(st.shadeMs);
            triangles = st.shadowCasterTriangles ? st.shadowCasterTriangles : triangles;
        }
        engine.setPreview(false);
        std::printf("  %-34s %8.1f ms %8.1f ms %8.1f ms   (shadow maps %.1f ms of %ld triangles each, shading %.1f ms)\n", what, percentile(ms, 50),
                    percentile(ms, 90), percentile(ms, 100), percentile(shadowMs, 50), triangles, percentile(shadeMs, 50));
        return true;
    };
    auto move = [&](Light& l, int i) { l.position[0] += (i % 2 ? -1.f : 1.f) * 0.01f * size; };
    for (bool preview : {false, true}) {
        for (int g : {1, 2, 4, 8}) {
            for (AreaShading mode : {AreaShading::OneShot, AreaShading::Ltc}) {
                if (g != 4 && mode == AreaShading::Ltc) continue;
                Rig rig = base;
                auto [light, fitMs] = areaLight(cases[1], size);
                (void)fitMs;
                light.shadowGrid = {g, g};
                light.areaShading = mode;
                rig.lights.push_back(light);
                char what[64];
                std::snprintf(what, sizeof what, "move, %dx%d shadows%s%s", g, g, mode == AreaShading::Ltc ? ", LTC" : "",
                              preview ? " (preview)" : "");
                if (!timeEdits(what, rig, preview, move)) return 3;
            }
        }
    }
    {
        Rig rig = base;
        auto [light, fitMs] = areaLight(cases[3], size);
        (void)fitMs;
        rig.lights.push_back(light);
        if (!timeEdits("pattern change (window <-> tubes)", rig, false,
                       [&](Light& l, int i) { l.pattern = i % 2 ? "window.png" : "tubes.png"; }))
            return 3;
        if (!timeEdits("intensity (a rescale)", rig, false, [&](Light& l, int i) { l.intensityCd = 1.f + 0.1f * float(i); })) return 3;
    }
    // A bent area light (paper 003 section 4.1): the same rectangle, its four corner chains bent
    // sideways by a quarter of their length; one corner's control point dragged.
    for (bool preview : {false, true}) {
        for (int g : {2, 4}) {
            Rig rig = base;
            auto [light, fitMs] = areaLight(cases[1], size);
            (void)fitMs;
            light.type = LightType::BentArea;
            light.coneAngleDeg = 60.f;
            light.penumbraDeg = 10.f;
            light.shadowGrid = {g, g};
            makeStraightCorners(light, 2.f * size);
            for (size_t i = 0; i < light.cornerPoints.size(); ++i) light.cornerPoints[i][2] += 0.125f * size * float(i % 4);
            rig.lights.push_back(light);
            char what[80];
            std::snprintf(what, sizeof what, "bent area cp edit, %dx%d%s", g, g, preview ? " (preview)" : "");
            if (!timeEdits(what, rig, preview, [&](Light& l, int i) { l.cornerPoints[1][1] += (i % 2 ? -1.f : 1.f) * 0.02f * size; }))
                return 3;
        }
    }
    return 0;
}
