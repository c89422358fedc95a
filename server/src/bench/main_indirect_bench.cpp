// dfb-indirect-bench: the server side of an indirect-editing drag (issue 17 point 9), per mode:
// the pick of the pointer's pixel (Picker) plus the solve of the edited light (IndirectEdit.h),
// and update -> frame (pick + solve + the engine's preview frame + JPEG encoding), as the
// protocol's drag updates will run them. Each update solves from the light as it was when the
// drag began. A benchmark prints numbers; nothing here passes or fails.
//
//   dfb-indirect-bench SHOT.exr [--scene SCENE] [--updates N] [--quality Q]

#include <dfb/core/Stats.h>
#include <dfb/gbuffer/ExrIO.h>
#include <dfb/gbuffer/Scene.h>
#include <dfb/server/Engine.h>
#include <dfb/server/ImageCodec.h>
#include <dfb/server/IndirectEdit.h>
#include <dfb/server/Picker.h>

#include "BenchShot.h"

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <functional>
#include <iostream>
#include <optional>

using namespace dfb;
using glm::dvec3;
using Clock = std::chrono::steady_clock;

namespace {

double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// What a drag began on: the pixel and what the picker found there.
struct Grab {
    int x = 0, y = 0;
    PickResult at;
    OccluderResult occluder;
};

// One mode: which light it edits, whether it needs an occluder under the grabbed pixel, and the
// solve of one update from the begin light, the grab and the pointer's new pick.
struct Mode {
    const char* name;
    bool bendy;
    bool needsOccluder;
    std::function<Result<indirect::Edit>(const Light&, const Grab&, const PickResult&, const dvec3& eye)> solve;
};

dvec3 d(const glm::vec3& v) { return dvec3(v); }

// A BendyLight bent sideways over a length fitted to the scene (as dfb-bench's).
void bend(Light& l, const Bounds& b) {
    const float size = glm::length(b.max - b.min);
    makeStraightChain(l, 0.6f * size, 2);
    l.controlPoints[2][2] += 0.08f * size;
    l.controlPoints[3][2] += 0.2f * size;
}

// The first pixel on a coarse scan from the image's centre outwards whose grab `ok` accepts.
std::optional<Grab> findGrab(const Picker& picker, const Rig& rig, int width, int height, bool needsOccluder,
                             const std::function<bool(const Grab&)>& ok) {
    for (int r = 0; r < std::max(width, height) / 2; r += 4)
        for (int dy = -r; dy <= r; dy += 4)
            for (int dx = -r; dx <= r; dx += 4) {
                if (std::max(std::abs(dx), std::abs(dy)) != r) continue;
                Grab g;
                g.x = width / 2 + dx;
                g.y = height / 2 + dy;
                auto p = picker.pick(g.x, g.y);
                if (!p) continue;
                g.at = p.value();
                if (needsOccluder) {
                    auto o = picker.occluder(rig, rig.lights[0].name, g.x, g.y);
                    // An occluder well off the receiver (a tenth of the way to the light): near a
                    // contact eq. 11's ratio |Pl - P| / |P - M| flings the light away per pixel.
                    if (!o || !o->found || glm::length(o->S - g.at.P) < 0.1f * glm::length(o->rayFrom - g.at.P)) continue;
                    g.occluder = o.value();
                }
                if (ok(g)) return g;
            }
    return std::nullopt;
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"dfb-indirect-bench: pick + solve and update -> frame time of each indirect-editing mode"};
    std::string shotPath, scenePath;
    int updates = 30, quality = 85;
    app.add_option("shot", shotPath, "deep framebuffer EXR")->required();
    app.add_option("--scene", scenePath, "shadow casters (default: the shot's source scene)");
    app.add_option("--updates", updates, "drag updates per mode")->check(CLI::Range(1, 10000));
    app.add_option("--quality", quality, "JPEG quality")->check(CLI::Range(1, 100));
    CLI11_PARSE(app, argc, argv);

    bench::BenchShot opened;
    if (int rc = bench::openBenchShot("dfb-indirect-bench", shotPath, scenePath, opened)) return rc;
    auto picker = Picker::create(opened.shot, opened.casters);
    if (!picker) {
        std::cerr << "dfb-indirect-bench: " << picker.error().toString() << "\n";
        return 3;
    }
    const Bounds& b = opened.scene.bounds;
    const Rig base = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    Rig bent = base;
    bend(bent.lights[0], b);
    const dvec3 eye = d(opened.shot.camera.position());
    const int W = opened.shot.width, H = opened.shot.height;

    using indirect::Edit;
    auto hitPoint = [](const PickResult& p) { return d(p.P); };
    const std::vector<Mode> modes = {
        {"shadow drag", false, true,
         [&](const Light& l, const Grab& g, const PickResult& now, const dvec3&) {
             return indirect::shadowDrag(l, d(g.occluder.S), hitPoint(g.at), hitPoint(now));
         }},
        {"hotspot drag", false, false,
         [&](const Light& l, const Grab& g, const PickResult& now, const dvec3&) {
             return indirect::hotspotDrag(l, hitPoint(g.at), hitPoint(now));
         }},
        {"highlight drag", false, false,
         [&](const Light& l, const Grab&, const PickResult& now, const dvec3& e) {
             return indirect::highlightDrag(l, hitPoint(now), d(now.N), glm::normalize(e - hitPoint(now)));
         }},
        {"physical shadow move", false, true,
         [&](const Light& l, const Grab& g, const PickResult& now, const dvec3&) {
             return indirect::physicalShadowMove(l, d(g.occluder.S), hitPoint(g.at), hitPoint(now));
         }},
        {"diffuse move", false, false,
         [&](const Light& l, const Grab& g, const PickResult& now, const dvec3&) {
             return indirect::diffuseMove(l, hitPoint(g.at), d(g.at.N), hitPoint(now), d(now.N));
         }},
        {"Bendy shadow drag", true, true,
         [&](const Light& l, const Grab& g, const PickResult& now, const dvec3&) {
             return indirect::shadowDrag(l, d(g.occluder.S), hitPoint(g.at), hitPoint(now));
         }},
        {"Bendy hotspot drag", true, false,
         [&](const Light& l, const Grab& g, const PickResult& now, const dvec3&) {
             return indirect::hotspotDrag(l, hitPoint(g.at), hitPoint(now));
         }},
        {"Bendy highlight, cp 3-4", true, false,
         [&](const Light& l, const Grab&, const PickResult& now, const dvec3& e) {
             return indirect::highlightDrag(l, hitPoint(now), d(now.N), glm::normalize(e - hitPoint(now)), {3, 4});
         }},
    };

    std::printf("device:   %s\n", opened.engine->deviceDescription().c_str());
    std::printf("shot:     %s, %dx%d, %zu caster triangles (BVH %.1f ms)\n", shotPath.c_str(), W, H,
                picker.value()->stats().casterTriangles, picker.value()->stats().bvhBuildMs);
    std::printf("updates:  %d per mode, the pointer 2 px right per update from the grabbed pixel; preview frames\n",
                updates);
    std::printf("          (as during a drag); update -> frame = pick + solve + render + JPEG (q%d)\n\n", quality);
    std::printf("%-24s %-9s %10s %10s %6s | %10s %10s %10s | %s\n", "mode", "grabbed", "pick+solve", "p90", "iter",
                "update->fr", "p90", "max", "refused");

    for (const Mode& m : modes) {
        const Rig& start = m.bendy ? bent : base;
        // Warm the engine (and the picker's deformed hierarchy) on the begin rig, outside the timing.
        opened.engine->setPreview(false);
        if (!opened.engine->render(start)) return 3;
        const auto t0 = Clock::now();
        auto grab = findGrab(*picker.value(), start, W, H, m.needsOccluder, [&](const Grab& g) {
            auto probe = picker.value()->pick(std::min(g.x + 2, W - 1), g.y);
            return probe && m.solve(start.lights[0], g, probe.value(), eye).ok();
        });
        const double grabMs = msSince(t0);
        if (!grab) {
            std::printf("%-24s no pixel found where the mode applies\n", m.name);
            continue;
        }
        opened.engine->setPreview(true);
        Rig rig = start;
        std::vector<double> solveMs, frameMs, iterations;
        int refused = 0;
        std::string firstRefusal;
        for (int i = 1; i <= updates; ++i) {
            const int x = std::min(grab->x + 2 * i, W - 1);
            const auto u0 = Clock::now();
            auto now = picker.value()->pick(x, grab->y);
            Result<Edit> e = now ? m.solve(start.lights[0], *grab, now.value(), eye) : Result<Edit>(now.error());
            const double s = msSince(u0);
            if (!e) {
                if (!refused++) firstRefusal = e.error().message; // a refused update changes nothing: no frame
                continue;
            }
            rig.lights[0] = e->light;
            ++rig.version;
            auto img = opened.engine->render(rig);
            if (!img || !encodeJpeg(img.value(), quality)) return 4;
            solveMs.push_back(s);
            frameMs.push_back(msSince(u0));
            iterations.push_back(double(e->iterations));
        }
        opened.engine->setPreview(false);
        if (solveMs.empty()) {
            std::printf("%-24s every update refused (%d): %s\n", m.name, refused, firstRefusal.c_str());
            continue;
        }
        std::printf("%-24s (%3d,%3d) %8.3fms %8.3fms %6.0f | %8.2fms %8.2fms %8.2fms | %d  (grab search %.0f ms)\n",
                    m.name, grab->x, grab->y, percentile(solveMs, 50), percentile(solveMs, 90), percentile(iterations, 50),
                    percentile(frameMs, 50), percentile(frameMs, 90), percentile(frameMs, 100), refused, grabMs);
        if (refused) std::printf("%-24s   first refusal: %s\n", "", firstRefusal.c_str());
    }
    const PickerStats st = picker.value()->stats();
    std::printf("\nBendyLight deformed hierarchy: %.1f ms for %zu triangles (%d built)\n", st.lastDeformedBuildMs,
                st.lastDeformedTriangles, st.deformedBuilds);
    return 0;
}
