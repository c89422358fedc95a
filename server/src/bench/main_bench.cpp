// dfb-bench: server-side time from an edit to an encoded JPEG frame, per kind of edit, with the
// breakdown per stage. A benchmark prints numbers; nothing here passes or fails.
//
//   dfb-bench SHOT.exr [--scene SCENE] [--edits N] [--quality Q]

#include <dfb/core/Version.h>
#include <dfb/gbuffer/Baker.h>
#include <dfb/gbuffer/ExrIO.h>
#include <dfb/gbuffer/Scene.h>
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
#include <functional>
#include <iostream>

#include <dfb/core/Stats.h>

using namespace dfb;

namespace {

// Bends `l` into a BendyLight curving sideways over a length fitted to the scene (the drag
// benchmark's light), keeping its cone and shadow-map size.
void bend(Light& l, const Bounds& b) {
    const float size = glm::length(b.max - b.min);
    makeStraightChain(l, 0.6f * size, 2);
    l.controlPoints[2][2] += 0.08f * size;
    l.controlPoints[3][2] += 0.2f * size;
}

// Median edit -> JPEG time of `edits` edits made by `apply`.
double medianEditMs(Engine& engine, Rig& rig, int edits, int quality, const std::function<void(Rig&, int)>& apply) {
    std::vector<double> t;
    for (int i = 0; i < edits; ++i) {
        apply(rig, i);
        ++rig.version;
        const auto t0 = std::chrono::steady_clock::now();
        auto img = engine.render(rig);
        if (!img || !encodeJpeg(img.value(), quality)) return -1;
        t.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    return percentile(t, 50);
}

// The scaling tables: one scene baked at several sizes, and many scenes at one size.
struct ScalingRow {
    double intensity = 0, cone = 0, position = 0, bendy = 0;
};

ScalingRow measureScene(const Scene& scene, int width, int height, int edits, int quality) {
    BakeOptions o;
    o.width = width;
    o.height = height;
    auto shot = bake(scene, o);
    if (!shot) return {-1, -1, -1, -1};
    auto engine = Engine::create(shot.value(), shadowCasters(scene));
    if (!engine) return {-1, -1, -1, -1};
    const Bounds& b = scene.bounds;
    Rig rig = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    if (!engine.value()->render(rig)) return {-1, -1, -1, -1};
    ScalingRow r;
    Engine& e = *engine.value();
    r.intensity = medianEditMs(e, rig, edits, quality, [](Rig& g, int i) { g.lights[0].intensityCd *= (i % 2) ? 1.01f : 0.99f; });
    r.cone = medianEditMs(e, rig, edits, quality, [](Rig& g, int i) { g.lights[0].coneAngleDeg = 26.f + 0.05f * float(i % 40); });
    const float x0 = rig.lights[0].position[0], step = 0.002f * glm::length(b.max - b.min);
    r.position = medianEditMs(e, rig, edits, quality, [=](Rig& g, int i) { g.lights[0].position[0] = x0 + step * float(i % 2); });
    bend(rig.lights[0], b);
    if (!e.render(rig)) return r;
    const float z0 = rig.lights[0].controlPoints[3][2];
    r.bendy = medianEditMs(e, rig, edits, quality, [=](Rig& g, int i) { g.lights[0].controlPoints[3][2] = z0 + step * float(i % 20); });
    return r;
}

} // namespace

int main(int argc, char** argv) {
    dfb::keepFreedMemoryForFrames();
    CLI::App app{"dfb-bench: edit-to-frame time of the relight engine"};
    app.set_version_flag("--version", dfb::versionText("dfb-bench"));
    std::string shotPath, scenePath;
    int edits = 100, quality = 85;
    app.add_option("shot", shotPath, "deep framebuffer EXR")->required();
    app.add_option("--scene", scenePath, "shadow casters (default: the shot's source scene)");
    app.add_option("--edits", edits, "edits per kind")->check(CLI::Range(1, 100000));
    app.add_option("--quality", quality, "JPEG quality")->check(CLI::Range(1, 100));
    bool scaling = false;
    std::string assets = DFB_DEFAULT_ASSETS;
    app.add_flag("--scaling", scaling, "also print the scaling tables: time vs pixels (480x270 to 1920x1080, the shot's "
                                      "scene) and vs triangles (the asset scenes at 480x270)");
    app.add_option("--assets", assets, "folder of the asset scenes for the triangles table");
    std::string only;
    app.add_option("--only", only, "time only the edit kinds whose name contains this text (skips the lights table)");
    if (const int rc = dfb::parseCommandLine(app, argc, argv, "dfb-bench"); rc >= 0) return rc;

    bench::BenchShot opened;
    if (int rc = bench::openBenchShot("dfb-bench", shotPath, scenePath, opened)) return rc;
    const Bounds& b = opened.scene.bounds;
    Rig rig = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    if (!opened.engine->render(rig).ok()) return 3; // warm-up: first frame fills every cache

    std::printf("device:   %s\n", opened.engine->deviceDescription().c_str());
    std::printf("shot:     %s, %dx%d, %zu shadow-casting triangles, %zu lights, shadow map %d\n", shotPath.c_str(),
                opened.shot.width, opened.shot.height, opened.scene.triangleCount(), rig.lights.size(), rig.lights[0].shadowMapSize);
    std::printf("edits:    %d per kind; time = edit applied -> JPEG (q%d) ready, server side\n\n", edits, quality);
    std::printf("%-22s %9s %9s %9s | %8s %8s %9s %9s %8s\n", "edit", "median", "p90", "max", "shadow", "shade",
                "composite", "readback", "encode");

    struct Kind {
        const char* name;
        std::function<void(Rig&, int)> apply;
    };
    const float x0 = rig.lights[0].position[0], z0 = rig.lights[0].position[2];
    const std::vector<Kind> kinds = {
        {"key intensity", [](Rig& r, int i) { r.lights[0].intensityCd *= (i % 2) ? 1.01f : 0.99f; }},
        {"key colour", [](Rig& r, int i) { r.lights[0].color[1] = 0.9f + 0.001f * float(i % 50); }},
        {"key cone angle", [](Rig& r, int i) { r.lights[0].coneAngleDeg = 26.f + 0.05f * float(i % 40); }},
        {"key position", [x0, z0](Rig& r, int i) {
             const float a = 0.02f * float(i);
             r.lights[0].position[0] = x0 + 0.3f * std::cos(a);
             r.lights[0].position[2] = z0 + 0.3f * std::sin(a);
         }},
        {"exposure", [](Rig& r, int i) { r.exposureStops = 0.01f * float(i % 20); }},
        // The fill becomes a shadowed point light (1024 cube map) on the first edit, then moves:
        // six cube faces + shading per edit.
        {"point light position", [](Rig& r, int i) {
             Light& f = r.lights[1];
             if (f.type != LightType::Point) {
                 f.type = LightType::Point;
                 f.shadow = true;
                 f.shadowMapSize = 1024;
             }
             f.position[0] += (i % 2) ? 0.01f : -0.01f;
         }},
        // The key light becomes a BendyLight (2048 shadow map) on the first edit; then one control
        // point is dragged: deformed shadow map + BendyLight shading per edit.
        {"BendyLight ctrl point", [&b](Rig& r, int i) {
             if (r.lights[0].type != LightType::Bendy) bend(r.lights[0], b);
             r.lights[0].controlPoints[3][2] = 0.2f * glm::length(b.max - b.min) + 0.01f * float(i % 20);
         }},
    };
    // The last kind again as the preview frames of a drag (progressive refinement: quarter-size
    // shadow maps; the server refines when the drag stops).
    std::vector<Kind> all = kinds;
    all.push_back({"  same, drag preview", kinds.back().apply});
    for (const Kind& k : all) {
        if (!only.empty() && std::string(k.name).find(only) == std::string::npos) continue;
        opened.engine->setPreview(&k == &all.back());
        std::vector<double> total, shadow, shade, composite, readback, encode;
        for (int i = 0; i < edits; ++i) {
            k.apply(rig, i);
            ++rig.version;
            const auto t0 = std::chrono::steady_clock::now();
            FrameStats st;
            auto img = opened.engine->render(rig, &st);
            if (!img) {
                std::cerr << "dfb-bench: " << img.error().toString() << "\n";
                return 3;
            }
            const auto t1 = std::chrono::steady_clock::now();
            auto jpeg = encodeJpeg(img.value(), quality);
            const auto t2 = std::chrono::steady_clock::now();
            if (!jpeg) return 4;
            total.push_back(std::chrono::duration<double, std::milli>(t2 - t0).count());
            encode.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
            shadow.push_back(st.shadowMs);
            shade.push_back(st.shadeMs);
            composite.push_back(st.compositeMs);
            readback.push_back(st.readbackMs);
        }
        std::printf("%-22s %7.2fms %7.2fms %7.2fms | %6.2fms %6.2fms %7.2fms %7.2fms %6.2fms\n", k.name,
                    percentile(total, 50), percentile(total, 90), percentile(total, 100), percentile(shadow, 50),
                    percentile(shade, 50), percentile(composite, 50), percentile(readback, 50),
                    percentile(encode, 50));
    }
    opened.engine->setPreview(false);
    std::printf("\n(stage columns are medians; the stages of one edit add up to its total)\n");
    if (!only.empty()) return 0;

    // Scaling with the number of lights: editing one light (position: shadow map + shading) of
    // a rig of N shadowed spot lights spread over the scene.
    std::printf("\nlights in the rig   edit one light's position (median)   edit its intensity (median)\n");
    double single = 0;
    for (int n : {1, 2, 8, 32, 64}) {
        Rig many = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
        const Light base = many.lights[0];
        many.lights.clear();
        for (int i = 0; i < n; ++i) {
            Light l = base;
            l.name = "light" + std::to_string(i);
            const float a = 6.2831853f * float(i) / float(n);
            l.position[0] += 1.5f * std::cos(a);
            l.position[2] += 1.5f * std::sin(a);
            l.intensityCd /= float(n);
            l.shadowMapSize = 1024;
            many.lights.push_back(l);
        }
        if (!opened.engine->render(many).ok()) return 3;
        std::vector<double> pos, inten;
        for (int i = 0; i < std::max(10, edits / 5); ++i) {
            many.lights[0].position[0] += (i % 2) ? 0.01f : -0.01f;
            auto t0 = std::chrono::steady_clock::now();
            auto img = opened.engine->render(many);
            if (!img || !encodeJpeg(img.value(), quality)) return 3;
            pos.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
            many.lights[0].intensityCd *= (i % 2) ? 1.01f : 0.99f;
            t0 = std::chrono::steady_clock::now();
            img = opened.engine->render(many);
            if (!img || !encodeJpeg(img.value(), quality)) return 3;
            inten.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        }
        const double p50 = percentile(pos, 50);
        if (n == 1) single = p50;
        std::printf("%17d   %20.2f ms (%.2fx of one)   %20.2f ms\n", n, p50, p50 / single, percentile(inten, 50));
    }
    if (!scaling) return 0;

    const int n = std::max(5, edits / 5);
    std::printf("\nscaling with pixels: %s baked at each size, default rig, median of %d edits -> JPEG\n",
                opened.shot.sourcePath.c_str(), n);
    std::printf("%-10s %10s | %10s %10s %10s %12s\n", "size", "pixels", "intensity", "cone", "position", "BendyLight cp");
    for (auto [w, h] : {std::pair{480, 270}, {960, 540}, {1440, 810}, {1920, 1080}}) {
        const ScalingRow r = measureScene(opened.scene, w, h, n, quality);
        std::printf("%4dx%-5d %10d | %8.1fms %8.1fms %8.1fms %10.1fms\n", w, h, w * h, r.intensity, r.cone, r.position, r.bendy);
    }
    std::printf("\nscaling with triangles: asset scenes at 480x270 (automatic framing), default rig, median of %d edits\n", n);
    std::printf("%-34s %10s | %10s %10s %10s %12s\n", "scene", "triangles", "intensity", "cone", "position", "BendyLight cp");
    for (const char* name : {"Box.glb", "stanford-bunny-lowres.glb", "utah-teapot.glb", "WaterBottle.glb", "stanford-dragon-48k.glb",
                             "stanford-bunny.glb", "FlightHelmet-notex.glb", "MetalRoughSpheresNoTextures.glb"}) {
        const std::string path = (std::filesystem::path(assets) / name).string();
        auto sc = loadScene(path);
        if (!sc) {
            std::printf("%-34s %s\n", name, sc.error().toString().c_str());
            continue;
        }
        const ScalingRow r = measureScene(sc.value(), 480, 270, n, quality);
        std::printf("%-34s %10zu | %8.1fms %8.1fms %8.1fms %10.1fms\n", name, sc->triangleCount(), r.intensity, r.cone,
                    r.position, r.bendy);
    }
    return 0;
}
