// dfb-bendy-bench: what BendyLights cost. Prints
//  1. the deformed shadow-map pass (adaptive tessellation) in ms versus triangles and map size;
//  2. the deformation cost per vertex (CPU double/float, GPU compute);
//  3. edit -> encoded frame for a control-point drag on a shot (default: the bundled scene).
// A benchmark prints numbers; nothing passes or fails.
//
//   dfb-bendy-bench [--shot SHOT.exr] [--assets DIR] [--edits N]

#include "engine/GpuInterface.h"

#include <dfb/core/Version.h>
#include <dfb/gbuffer/Baker.h>
#include <dfb/gbuffer/ExrIO.h>
#include <dfb/gl/Context.h>
#include <dfb/gl/Objects.h>
#include <dfb/server/BendyChain.h>
#include <dfb/server/Engine.h>
#include <dfb/server/ImageCodec.h>

#include <dfb/core/CommandLine.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <random>

namespace dfb::shaders {
std::string_view serverShader(std::string_view name);
}

using namespace dfb;
using Clock = std::chrono::steady_clock;

namespace {

double ms(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); }
double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0 : v[v.size() / 2];
}

// A key light over the scene's bounds, bent sideways by ~65 degrees (as in the tests).
Light bentLight(const Bounds& b, int mapSize) {
    const Rig def = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    Light l = def.lights[0];
    const glm::vec3 target = b.center();
    const float len = glm::length(glm::vec3(l.position[0], l.position[1], l.position[2]) - target);
    l.name = "bendy";
    l.type = LightType::Bendy;
    l.shadowMapSize = mapSize;
    const float tanTheta = std::tan(glm::radians(l.coneAngleDeg));
    const float u = len / 5.f;
    l.controlPoints = {{1.5f * u, 0, 0}, {3.f * u, 0, 0}, {4.2f * u, 0, 0.6f * u}, {4.8f * u, 0, 1.9f * u}};
    l.radii = {0.f, 1.5f * u * tanTheta, 3.f * u * tanTheta, 3.6f * u * tanTheta, 4.1f * u * tanTheta};
    l.colors.assign(5, Vec3{1, 1, 1});
    return l;
}

} // namespace

int main(int argc, char** argv) {
    dfb::keepFreedMemoryForFrames();
    CLI::App app{"dfb-bendy-bench: the cost of BendyLights"};
    app.set_version_flag("--version", dfb::versionText("dfb-bendy-bench"));
    std::string shotPath, assets = DFB_DEFAULT_ASSETS;
    int edits = 50;
    app.add_option("--shot", shotPath, "shot for the edit -> frame timing (default: bake the bundled scene at 960x540)");
    app.add_option("--assets", assets, "folder with MetalRoughSpheresNoTextures.glb (the 1M-triangle case)");
    app.add_option("--edits", edits, "edits per measurement")->check(CLI::Range(3, 10000));
    int only = 0;
    app.add_option("--only", only, "run only section 1, 2 or 3")->check(CLI::Range(0, 3));
    if (const int rc = dfb::parseCommandLine(app, argc, argv, "dfb-bendy-bench"); rc >= 0) return rc;

    // 1. Shadow pass versus triangles and map size.
    if (only == 0 || only == 1) {
    std::printf("1. deformed shadow-map pass (median of %d renders, adaptive tessellation up to 64)\n", edits);
    std::printf("%-34s %10s %8s %10s %10s\n", "scene", "triangles", "map", "shadow ms", "plain spot");
    struct Case {
        std::string path;
    };
    std::vector<std::string> scenes = {DFB_SOURCE_DIR "/scenes/tabletop.glb", assets + "/MetalRoughSpheresNoTextures.glb"};
    if (std::getenv("DFB_BENCH_QUICK")) scenes.resize(1);
    for (const std::string& path : scenes) {
        auto scene = loadScene(path);
        if (!scene) {
            std::printf("%-34s %s\n", std::filesystem::path(path).filename().c_str(), scene.error().toString().c_str());
            continue;
        }
        BakeOptions o;
        o.width = 240;
        o.height = 135;
        auto shot = bake(scene.value(), o);
        if (!shot) return 3;
        auto engine = Engine::create(shot.value(), shadowCasters(scene.value()));
        if (!engine) {
            std::fprintf(stderr, "%s\n", engine.error().toString().c_str());
            return 3;
        }
        if (const char* lim = std::getenv("DFB_SUBDIVISION_LIMIT")) engine.value()->setShadowSubdivisionLimit(std::atoi(lim));
        for (int size : {1024, 2048, 4096}) {
            Rig rig;
            rig.lights = {bentLight(scene->bounds, size)};
            Light spot = rig.lights[0];
            spot.type = LightType::Spot;
            spot.name = "spot";
            std::vector<double> bendyMs, spotMs;
            for (int i = 0; i < edits; ++i) {
                rig.lights[0].controlPoints[2][2] += 1e-4f * float(i % 2 ? 1 : -1); // a drag: new shadow map
                FrameStats st;
                if (!engine.value()->render(rig, &st)) return 3;
                if (i > 0) bendyMs.push_back(st.shadowMs);
            }
            Rig spotRig;
            spotRig.lights = {spot};
            for (int i = 0; i < std::min(edits, 10); ++i) {
                spotRig.lights[0].position[0] += 1e-4f;
                FrameStats st;
                if (!engine.value()->render(spotRig, &st)) return 3;
                if (i > 0) spotMs.push_back(st.shadowMs);
            }
            std::printf("%-34s %10zu %8d %10.2f %10.2f\n", std::filesystem::path(path).filename().c_str(),
                        scene->triangleCount(), size, median(bendyMs), median(spotMs));
        }
    }

    }
    // 2. Deformation per vertex.
    if (only == 0 || only == 2) {
        std::printf("\n2. deformation Q -> Q' (inverse map + eq. 7) per vertex, 2-segment chain\n");
        auto scene = loadScene(DFB_SOURCE_DIR "/scenes/tabletop.glb");
        if (!scene) return 2;
        const Light l = bentLight(scene->bounds, 2048);
        const auto chd = chainFromLight<double>(l);
        const auto chf = chainFromLight<float>(l);
        std::mt19937 rng(1);
        std::uniform_real_distribution<float> u(0.f, 1.f);
        const size_t N = 1 << 20;
        std::vector<glm::vec4> pts(N);
        const Bounds& b = scene->bounds;
        for (auto& p : pts) p = glm::vec4(b.min + (b.max - b.min) * glm::vec3(u(rng), u(rng), u(rng)), 1.f);
        double sink = 0;
        auto t0 = Clock::now();
        for (size_t i = 0; i < N / 8; ++i) {
            const auto c = lightmath::inverseMap(chd, glm::dvec3(pts[i]));
            if (c.valid) sink += lightmath::deformedPoint(chd, c).x;
        }
        auto t1 = Clock::now();
        for (size_t i = 0; i < N / 8; ++i) {
            const auto c = lightmath::inverseMap(chf, glm::vec3(pts[i]));
            if (c.valid) sink += lightmath::deformedPoint(chf, c).x;
        }
        auto t2 = Clock::now();
        std::printf("CPU (1 core), double: %.0f ns per vertex; float: %.0f ns per vertex%s\n", ms(t0, t1) * 1e6 / double(N / 8),
                    ms(t1, t2) * 1e6 / double(N / 8), sink == 12345.678 ? " " : "");
        auto ctx = gl::Context::create();
        if (!ctx) return 3;
        const std::string src = "#version 450 core\n" + std::string(shaders::serverShader("common_bendy.glsl")) + R"(
layout(local_size_x = COMPUTE_GROUP_SIZE) in; // the deform pass's shape and bindings
layout(std430, binding = SSBO_CASTER_POSITIONS) readonly buffer Points { vec4 points[]; };
layout(std430, binding = SSBO_DEFORMED) writeonly buffer Results { vec4 results[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= uint(points.length())) return;
    TubeCoords c = inverseMap(points[i].xyz);
    results[i] = c.valid ? vec4(deformedPoint(c), 1.0) : vec4(0.0);
})";
        auto program = gl::buildProgram({{GL_COMPUTE_SHADER, "bench.comp", src}});
        if (!program) {
            std::fprintf(stderr, "%s\n", program.error().toString().c_str());
            return 3;
        }
        const engine::BendyBlock block = engine::toBendyBlock(chf, false);
        gl::Buffer ubo = gl::makeBuffer(&block, sizeof block);
        gl::Buffer in = gl::makeBuffer(pts.data(), pts.size() * sizeof(glm::vec4));
        gl::Buffer out = gl::makeBuffer(nullptr, pts.size() * sizeof(glm::vec4));
        glUseProgram(program->id());
        glBindBufferBase(GL_UNIFORM_BUFFER, engine::UBO_BENDY, ubo.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, engine::SSBO_CASTER_POSITIONS, in.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, engine::SSBO_DEFORMED, out.id());
        std::vector<double> runs;
        for (int r = 0; r < 4; ++r) {
            auto a = Clock::now();
            glDispatchCompute(GLuint(N / engine::COMPUTE_GROUP_SIZE), 1, 1);
            glFinish();
            runs.push_back(ms(a, Clock::now()));
        }
        std::printf("GPU compute (%s): %.1f ns per vertex (%zu vertices in %.1f ms)\n", ctx.value()->description().c_str(),
                    median(runs) * 1e6 / double(N), N, median(runs));
    }

    // 3. Edit -> encoded frame for a control-point drag.
    if (only == 0 || only == 3) {
        std::printf("\n3. control-point drag, edit -> JPEG, key light bent, fill spot cached\n");
        DeepBuffer shot;
        auto scene = loadScene(DFB_SOURCE_DIR "/scenes/tabletop.glb");
        if (!scene) return 2;
        if (!shotPath.empty()) {
            auto r = readDeepBuffer(shotPath);
            if (!r) return 2;
            shot = std::move(r.value());
        } else {
            BakeOptions o;
            auto r = bake(scene.value(), o);
            if (!r) return 3;
            shot = std::move(r.value());
        }
        auto engine = Engine::create(shot, shadowCasters(scene.value()));
        if (!engine) return 3;
        const Bounds& b = scene->bounds;
        Rig rig = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
        rig.lights[0] = bentLight(b, 2048);
        if (!engine.value()->render(rig)) return 3;
        std::vector<double> total, shadow, shade, composite, encode;
        for (int i = 0; i < edits; ++i) {
            rig.lights[0].controlPoints[3][2] = 1.9f + 0.01f * float(i % 20);
            const auto a = Clock::now();
            FrameStats st;
            auto img = engine.value()->render(rig, &st);
            const auto m = Clock::now();
            auto jpeg = encodeJpeg(img.value(), 85);
            const auto e = Clock::now();
            total.push_back(ms(a, e));
            shadow.push_back(st.shadowMs);
            shade.push_back(st.shadeMs);
            composite.push_back(st.compositeMs + st.readbackMs);
            encode.push_back(ms(m, e));
        }
        std::printf("%dx%d: median %.1f ms (shadow map %.1f, shading %.1f, composite+readback %.1f, encode %.1f)\n", shot.width,
                    shot.height, median(total), median(shadow), median(shade), median(composite), median(encode));
    }
    return 0;
}
