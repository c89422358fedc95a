// dfb-indirect-bench: the server side of an indirect-editing drag (issue 17 point 9), per mode:
// the pick of the pointer's pixel plus the solve of the edited light (dfb/server/Drag.h, what the
// server runs for each drag update), and update -> frame (pick + solve + the engine's preview
// frame + JPEG encoding). Each update solves from the light as it was when the
// drag began. A benchmark prints numbers; nothing here passes or fails.
//
//   dfb-indirect-bench SHOT.exr [--scene SCENE] [--updates N] [--quality Q]

#include <dfb/core/Version.h>
#include <dfb/core/Stats.h>
#include <dfb/gbuffer/ExrIO.h>
#include <dfb/gbuffer/Scene.h>
#include <dfb/server/Engine.h>
#include <dfb/server/ImageCodec.h>
#include <dfb/server/Drag.h>

#include "BenchShot.h"

#include <dfb/core/CommandLine.h>
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <optional>

using namespace dfb;
using Clock = std::chrono::steady_clock;

namespace {

double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// One row: a drag mode on the key light (straight or bent), optionally on selected control points.
struct Mode {
    const char* name;
    protocol::DragMode mode;
    bool bendy;
    indirect::Selection points;
};

// A BendyLight bent sideways over a length fitted to the scene (as dfb-bench's).
void bend(Light& l, const Bounds& b) {
    const float size = glm::length(b.max - b.min);
    makeStraightChain(l, 0.6f * size, 2);
    l.controlPoints[2][2] += 0.08f * size;
    l.controlPoints[3][2] += 0.2f * size;
}

// The first pixel on a coarse scan from the image's centre outwards where the drag begins and
// its first update (2 px right) solves, as the server would run them (dfb/server/Drag.h).
std::optional<DragGrab> findGrab(const Picker& picker, const DeepBuffer& shot, const Rig& rig, const Mode& m) {
    const int width = shot.width, height = shot.height;
    for (int r = 0; r < std::max(width, height) / 2; r += 4)
        for (int dy = -r; dy <= r; dy += 4)
            for (int dx = -r; dx <= r; dx += 4) {
                if (std::max(std::abs(dx), std::abs(dy)) != r) continue;
                auto g = beginDrag(picker, shot, rig, {m.mode, rig.lights[0].name, width / 2 + dx, height / 2 + dy, m.points});
                if (!g) continue;
                // An occluder well off the receiver (a tenth of the way to the light): near a
                // contact eq. 11's ratio |Pl - P| / |P - M| flings the light away per pixel.
                if (g->occluder && glm::length(g->occluder->S - g->at.P) < 0.1f * glm::length(g->occluder->rayFrom - g->at.P)) continue;
                if (dragTo(picker, shot, g.value(), std::min(g->x + 2, width - 1), g->y)) return g.value();
            }
    return std::nullopt;
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"dfb-indirect-bench: pick + solve and update -> frame time of each indirect-editing mode"};
    app.set_version_flag("--version", dfb::versionText("dfb-indirect-bench"));
    std::string shotPath, scenePath;
    int updates = 30, quality = 85;
    app.add_option("shot", shotPath, "deep framebuffer EXR")->required();
    app.add_option("--scene", scenePath, "shadow casters (default: the shot's source scene)");
    app.add_option("--updates", updates, "drag updates per mode")->check(CLI::Range(1, 10000));
    app.add_option("--quality", quality, "JPEG quality")->check(CLI::Range(1, 100));
    if (const int rc = dfb::parseCommandLine(app, argc, argv, "dfb-indirect-bench"); rc >= 0) return rc;

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
    const int W = opened.shot.width, H = opened.shot.height;

    using protocol::DragMode;
    const std::vector<Mode> modes = {
        {"shadow drag", DragMode::Shadow, false, {}},
        {"hotspot drag", DragMode::Hotspot, false, {}},
        {"highlight drag", DragMode::Highlight, false, {}},
        {"physical shadow move", DragMode::PhysicalShadowMove, false, {}},
        {"diffuse move", DragMode::DiffuseMove, false, {}},
        {"Bendy shadow drag", DragMode::Shadow, true, {}},
        {"Bendy hotspot drag", DragMode::Hotspot, true, {}},
        {"Bendy highlight, cp 3-4", DragMode::Highlight, true, {3, 4}},
        {"Bendy local move, cp 3-4", DragMode::LocalShadowMove, true, {3, 4}},
        {"Bendy local scale", DragMode::LocalShadowScale, true, {}},
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
        auto grab = findGrab(*picker.value(), opened.shot, start, m);
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
            auto step = dragTo(*picker.value(), opened.shot, grab.value(), x, grab->y);
            if (!step) {
                if (!refused++) firstRefusal = step.error().message; // a refused update changes nothing: no frame
                continue;
            }
            rig.lights[0] = step->light;
            ++rig.version;
            auto img = opened.engine->render(rig);
            if (!img || !encodeJpeg(img.value(), quality)) return 4;
            solveMs.push_back(step->solveMs);
            frameMs.push_back(msSince(u0));
            iterations.push_back(double(step->iterations));
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
