// dfb-bake: bakes a glTF scene into a deep framebuffer EXR from a fixed camera.
//
// Exit codes: 0 success; 1 bad command line; 2 bad input (scene or camera); 3 GPU/EGL failure;
// 4 the output could not be written.

#include <dfb/gbuffer/Baker.h>
#include <dfb/gbuffer/ExrIO.h>
#include <dfb/gbuffer/Scene.h>

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <iostream>

namespace {

int exitCodeFor(dfb::ErrorCode c) {
    switch (c) {
    case dfb::ErrorCode::GpuError: return 3;
    case dfb::ErrorCode::IoError: return 4;
    default: return 2;
    }
}

int printInfo(const std::string& path) {
    auto b = dfb::readDeepBuffer(path);
    if (!b) {
        std::cerr << "dfb-bake: " << b.error().toString() << "\n";
        return 2;
    }
    size_t covered = 0;
    for (float a : b->A) covered += a > 0.f;
    std::printf("file:        %s\n", path.c_str());
    std::printf("resolution:  %d x %d (%zu covered pixels)\n", b->width, b->height, covered);
    std::printf("samples:     1 per pixel\n");
    std::printf("camera:      %s, yfov %.3f deg, aspect %.4f, near %g, far %g\n", b->camera.name.c_str(),
                double(b->camera.yfovRadians) * 57.29577951308232, double(b->camera.aspect), double(b->camera.znear),
                double(b->camera.zfar));
    const glm::vec3 eye = b->camera.position();
    std::printf("eye:         %g %g %g\n", double(eye.x), double(eye.y), double(eye.z));
    std::printf("source:      %s\n", b->sourcePath.c_str());
    std::printf("objects:     %zu\n", b->objectNames.size());
    for (size_t i = 0; i < b->objectNames.size(); ++i) std::printf("  %3zu %s\n", i + 1, b->objectNames[i].c_str());
    std::printf("materials:   %zu\n", b->materialNames.size());
    for (size_t i = 0; i < b->materialNames.size(); ++i) std::printf("  %3zu %s\n", i + 1, b->materialNames[i].c_str());
    return 0;
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"dfb-bake: bake a glTF scene into a deep framebuffer (OpenEXR) from a fixed camera"};
    std::string scenePath, outPath, infoPath;
    dfb::BakeOptions opts;
    std::vector<float> lookFrom, lookAt;
    app.add_option("scene", scenePath, "glTF scene (.glb or .gltf)");
    app.add_option("-o,--output", outPath, "output EXR path");
    app.add_option("--width", opts.width, "image width in pixels")->check(CLI::Range(1, 16384));
    app.add_option("--height", opts.height, "image height in pixels")->check(CLI::Range(1, 16384));
    app.add_option("--camera", opts.cameraName, "glTF camera to bake from (default: the first one, else automatic framing)");
    app.add_option("--look-from", lookFrom, "eye position x,y,z (with --look-at)")->expected(3)->delimiter(',');
    app.add_option("--look-at", lookAt, "target position x,y,z (with --look-from)")->expected(3)->delimiter(',');
    app.add_option("--fov", opts.fovDegrees, "vertical field of view in degrees for --look-from or automatic framing")
        ->check(CLI::Range(1.0, 170.0));
    app.add_option("--info", infoPath, "print what a baked EXR holds and exit");
    CLI11_PARSE(app, argc, argv);

    if (!infoPath.empty()) return printInfo(infoPath);
    if (scenePath.empty() || outPath.empty()) {
        std::cerr << "dfb-bake: a scene and -o OUTPUT are required (see --help)\n";
        return 1;
    }
    if (lookFrom.empty() != lookAt.empty()) {
        std::cerr << "dfb-bake: --look-from and --look-at go together\n";
        return 1;
    }
    if (!lookFrom.empty()) {
        opts.lookFrom = glm::vec3(lookFrom[0], lookFrom[1], lookFrom[2]);
        opts.lookAt = glm::vec3(lookAt[0], lookAt[1], lookAt[2]);
    }

    const auto t0 = std::chrono::steady_clock::now();
    auto scene = dfb::loadScene(scenePath);
    if (!scene) {
        std::cerr << "dfb-bake: " << scene.error().toString() << "\n";
        return exitCodeFor(scene.error().code);
    }
    auto buffer = dfb::bake(scene.value(), opts);
    if (!buffer) {
        std::cerr << "dfb-bake: " << buffer.error().toString() << "\n";
        return exitCodeFor(buffer.error().code);
    }
    if (auto s = dfb::writeDeepBuffer(buffer.value(), outPath); !s) {
        std::cerr << "dfb-bake: " << s.error().toString() << "\n";
        return 4;
    }
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    std::printf("baked %s (%zu triangles) -> %s, %dx%d, camera '%s', %.0f ms\n", scenePath.c_str(),
                scene->triangleCount(), outPath.c_str(), opts.width, opts.height, buffer->camera.name.c_str(), ms);
    return 0;
}
