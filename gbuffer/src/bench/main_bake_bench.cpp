// dfb-bake-bench: bake time, file size and peak memory for every scene of a folder (by default
// tests/assets), printed as a table. A benchmark prints numbers; nothing passes or fails.
//
//   dfb-bake-bench [DIR] [--width W] [--height H] [--samples N] [--env-rays N]
//
// Each scene is baked in a child process, so that its peak resident memory is its own.

#include <dfb/core/Version.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/gbuffer/Baker.h>
#include <dfb/gbuffer/ExrIO.h>

#include <dfb/core/CommandLine.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

struct Row {
    double loadMs = 0, bakeMs = 0, envMs = 0, writeMs = 0;
    uint64_t triangles = 0, sceneBytes = 0, samples = 0, fileBytes = 0;
    int ok = 0;
};

double ms(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); }

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"dfb-bake-bench: bake time and file size per scene"};
    app.set_version_flag("--version",
                         dfb::versionText("dfb-bake-bench") +
                             " (G-buffer format " + std::to_string(dfb::GBUFFER_FORMAT_VERSION) + ")");
    std::string dir = std::string(DFB_DEFAULT_ASSETS);
    dfb::BakeOptions o;
    o.width = 480;
    o.height = 270;
    app.add_option("dir", dir, "folder of .glb scenes");
    app.add_option("--width", o.width, "bake width")->check(CLI::Range(1, 16384));
    app.add_option("--height", o.height, "bake height")->check(CLI::Range(1, 16384));
    app.add_option("--samples", o.samples, "samples per pixel")->check(CLI::Range(1, dfb::MAX_SAMPLES_PER_PIXEL));
    int envRays = 64; // as dfb-bake
    app.add_option("--env-rays", envRays, "rays per sample for the environment transfer (0 = none)")
        ->check(CLI::Range(0, dfb::MAX_ENV_RAYS))
        ->capture_default_str();
    if (const int rc = dfb::parseCommandLine(app, argc, argv, "dfb-bake-bench"); rc >= 0) return rc;
    o.envRays = envRays;

    std::vector<fs::path> scenes;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir, ec))
        if (e.path().extension() == ".glb" || e.path().extension() == ".gltf") scenes.push_back(e.path());
    std::sort(scenes.begin(), scenes.end());
    if (scenes.empty()) {
        std::fprintf(stderr, "dfb-bake-bench: no .glb scenes in %s\n", dir.c_str());
        return 2;
    }
    const std::string out = (fs::temp_directory_path() / ("dfb_bake_bench_" + std::to_string(::getpid()) + ".exr")).string();
    std::printf("bake %dx%d, %d spp, %d environment rays per sample, each scene in its own process\n\n", o.width, o.height,
                o.samples, envRays);
    std::printf("%-34s %10s %9s %9s %9s %9s %9s %10s %10s %9s %7s\n", "scene", "triangles", "load", "bake", "env",
                "write", "file", "samples", "scene mem", "peak RSS", "RSS/mem");
    for (const fs::path& p : scenes) {
        int fds[2];
        if (::pipe(fds) != 0) return 3;
        const pid_t pid = ::fork();
        if (pid == 0) {
            ::close(fds[0]);
            Row r;
            const auto t0 = Clock::now();
            auto scene = dfb::loadScene(p.string());
            const auto t1 = Clock::now();
            if (scene) {
                r.triangles = scene->triangleCount();
                r.sceneBytes = scene->memoryBytes();
                dfb::EnvTransferStats env;
                o.envStats = &env;
                auto b = dfb::bake(scene.value(), o);
                const auto t2 = Clock::now();
                if (b) {
                    r.envMs = env.totalMs;
                    r.samples = b->sampleCount();
                    const bool written = dfb::writeDeepBuffer(b.value(), out).ok();
                    const auto t3 = Clock::now();
                    r.loadMs = ms(t0, t1);
                    r.bakeMs = ms(t1, t2) - r.envMs;
                    r.writeMs = ms(t2, t3);
                    r.fileBytes = written ? fs::file_size(out) : 0;
                    r.ok = written ? 1 : 0;
                    fs::remove(out);
                }
            }
            (void)!::write(fds[1], &r, sizeof r);
            ::_exit(0);
        }
        ::close(fds[1]);
        Row r;
        const bool got = ::read(fds[0], &r, sizeof r) == sizeof r;
        ::close(fds[0]);
        int status = 0;
        rusage ru{};
        ::wait4(pid, &status, 0, &ru);
        const double peakMiB = double(ru.ru_maxrss) / 1024.0;
        if (!got || !r.ok) {
            std::printf("%-34s failed\n", p.filename().c_str());
            continue;
        }
        std::printf("%-34s %10llu %7.0fms %7.0fms %7.0fms %7.0fms %7.2fMB %10llu %8.1fMB %7.0fMB %7.1fx\n",
                    p.filename().c_str(), (unsigned long long)r.triangles, r.loadMs, r.bakeMs, r.envMs, r.writeMs,
                    double(r.fileBytes) / 1e6,
                    (unsigned long long)r.samples, double(r.sceneBytes) / (1 << 20), peakMiB,
                    peakMiB / std::max(double(r.sceneBytes) / (1 << 20), 1e-3));
    }
    std::printf("\nbake: the raster passes and merging; env: the environment transfer's share of the bake (rays on\n"
                "the CPU over every core, the hierarchy included)\n"
                "scene mem: geometry flattened to world space plus decoded textures; peak RSS includes the\n"
                "process, the EGL/llvmpipe driver, the G-buffer render targets and the ray-casting hierarchy\n");
    return 0;
}
