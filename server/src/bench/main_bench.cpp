// dfb-bench: server-side time from an edit to an encoded JPEG frame, per kind of edit, with the
// breakdown per stage. A benchmark prints numbers; nothing here passes or fails.
//
//   dfb-bench SHOT.exr [--scene SCENE] [--edits N] [--quality Q]

#include <dfb/gbuffer/ExrIO.h>
#include <dfb/gbuffer/Scene.h>
#include <dfb/server/Engine.h>
#include <dfb/server/ImageCodec.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <iostream>

using namespace dfb;

namespace {

double percentile(std::vector<double> v, double p) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    const double idx = p * double(v.size() - 1);
    const size_t lo = size_t(std::floor(idx)), hi = size_t(std::ceil(idx));
    return v[lo] + (v[hi] - v[lo]) * (idx - double(lo));
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"dfb-bench: edit-to-frame time of the relight engine"};
    std::string shotPath, scenePath;
    int edits = 100, quality = 85;
    app.add_option("shot", shotPath, "deep framebuffer EXR")->required();
    app.add_option("--scene", scenePath, "shadow casters (default: the shot's source scene)");
    app.add_option("--edits", edits, "edits per kind")->check(CLI::Range(1, 100000));
    app.add_option("--quality", quality, "JPEG quality")->check(CLI::Range(1, 100));
    CLI11_PARSE(app, argc, argv);

    auto shot = readDeepBuffer(shotPath);
    if (!shot) {
        std::cerr << "dfb-bench: " << shot.error().toString() << "\n";
        return 2;
    }
    auto scene = loadScene(scenePath.empty() ? shot->sourcePath : scenePath);
    if (!scene) {
        std::cerr << "dfb-bench: " << scene.error().toString() << "\n";
        return 2;
    }
    ShadowGeometry casters = shadowCasters(scene.value());
    auto engine = Engine::create(shot.value(), casters);
    if (!engine) {
        std::cerr << "dfb-bench: " << engine.error().toString() << "\n";
        return 3;
    }
    const Bounds& b = scene->bounds;
    Rig rig = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    if (!engine.value()->render(rig).ok()) return 3; // warm-up: first frame fills every cache

    std::printf("device:   %s\n", engine.value()->deviceDescription().c_str());
    std::printf("shot:     %s, %dx%d, %zu shadow-casting triangles, %zu lights, shadow map %d\n", shotPath.c_str(),
                shot->width, shot->height, scene->triangleCount(), rig.lights.size(), rig.lights[0].shadowMapSize);
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
    };
    for (const Kind& k : kinds) {
        std::vector<double> total, shadow, shade, composite, readback, encode;
        for (int i = 0; i < edits; ++i) {
            k.apply(rig, i);
            ++rig.version;
            const auto t0 = std::chrono::steady_clock::now();
            FrameStats st;
            auto img = engine.value()->render(rig, &st);
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
                    percentile(total, 0.5), percentile(total, 0.9), percentile(total, 1.0), percentile(shadow, 0.5),
                    percentile(shade, 0.5), percentile(composite, 0.5), percentile(readback, 0.5),
                    percentile(encode, 0.5));
    }
    std::printf("\n(stage columns are medians; the stages of one edit add up to its total)\n");

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
        if (!engine.value()->render(many).ok()) return 3;
        std::vector<double> pos, inten;
        for (int i = 0; i < std::max(10, edits / 5); ++i) {
            many.lights[0].position[0] += (i % 2) ? 0.01f : -0.01f;
            auto t0 = std::chrono::steady_clock::now();
            auto img = engine.value()->render(many);
            if (!img || !encodeJpeg(img.value(), quality)) return 3;
            pos.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
            many.lights[0].intensityCd *= (i % 2) ? 1.01f : 0.99f;
            t0 = std::chrono::steady_clock::now();
            img = engine.value()->render(many);
            if (!img || !encodeJpeg(img.value(), quality)) return 3;
            inten.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        }
        const double p50 = percentile(pos, 0.5);
        if (n == 1) single = p50;
        std::printf("%17d   %20.2f ms (%.2fx of one)   %20.2f ms\n", n, p50, p50 / single, percentile(inten, 0.5));
    }
    return 0;
}
