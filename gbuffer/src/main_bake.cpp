// dfb-bake: bakes a glTF scene into a deep framebuffer EXR from a fixed camera, and inspects
// baked files.
//
//   dfb-bake SCENE -o SHOT.exr --width W --height H [--samples N] [--camera NAME] [--env-rays N] [--env-bands 3|5]
//   dfb-bake --info SHOT.exr
//   dfb-bake --list-cameras SCENE
//   dfb-bake --layer NAME SHOT.exr -o out.png
//
// Exit codes: 0 success; 1 bad command line; 2 bad input (scene, shot or camera); 3 GPU/EGL
// failure; 4 the output could not be written.

#include <dfb/core/Version.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/gbuffer/Baker.h>
#include <dfb/gbuffer/ExrIO.h>
#include <dfb/gbuffer/LayerImage.h>
#include <dfb/gbuffer/Scene.h>

#include <dfb/core/CommandLine.h>
#include <CLI/CLI.hpp>
#include <OpenImageIO/imageio.h>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <unistd.h>

namespace {

int exitCodeFor(dfb::ErrorCode c) {
    switch (c) {
    case dfb::ErrorCode::GpuError: return 3;
    case dfb::ErrorCode::IoError: return 4;
    default: return 2;
    }
}

// The scene's cameras, one a line, as --camera takes them (the first is the default).
int listCameras(const std::string& path) {
    dfb::LoadOptions lo;
    lo.loadImages = false;
    auto scene = dfb::loadScene(path, lo);
    if (!scene) {
        std::cerr << "dfb-bake: " << scene.error().toString() << "\n";
        return exitCodeFor(scene.error().code);
    }
    if (scene->cameras.empty()) {
        std::printf("%s has no cameras: dfb-bake frames the scene automatically (or give --look-from/--look-at)\n",
                    path.c_str());
        return 0;
    }
    for (size_t i = 0; i < scene->cameras.size(); ++i) {
        const dfb::SceneCamera& c = scene->cameras[i];
        const glm::mat4 toWorld = glm::inverse(c.worldToCamera);
        // + 0.f: no "-0.000" for a component that is zero.
        const glm::vec3 eye = glm::vec3(toWorld[3]) + 0.f, look = glm::normalize(-glm::vec3(toWorld[2])) + 0.f;
        char lens[64];
        if (c.orthographic) std::snprintf(lens, sizeof lens, "orthographic %.3g x %.3g", 2.0 * c.xmag, 2.0 * c.ymag);
        else std::snprintf(lens, sizeof lens, "perspective %.1f deg vertical", glm::degrees(double(c.yfovRadians)));
        std::printf("%s\t%s\tat %.3g,%.3g,%.3g\tlooking %.3f,%.3f,%.3f%s\n", c.name.c_str(), lens, eye.x, eye.y, eye.z, look.x,
                    look.y, look.z, i == 0 ? "\t(default)" : "");
    }
    return 0;
}

int printInfo(const std::string& path) {
    auto b = dfb::readDeepBuffer(path);
    if (!b) {
        std::cerr << "dfb-bake: " << b.error().toString() << "\n";
        return 2;
    }
    size_t covered = 0, maxSamples = 0;
    for (int y = 0; y < b->height; ++y)
        for (int x = 0; x < b->width; ++x) {
            covered += b->coverage(x, y) > 0.f;
            maxSamples = std::max<size_t>(maxSamples, b->pixelSamples(x, y));
        }
    std::printf("file:        %s\n", path.c_str());
    std::printf("resolution:  %d x %d (%zu covered pixels)\n", b->width, b->height, covered);
    std::printf("samples:     %d per pixel baked; %zu stored (%.3f per pixel, at most %zu in one pixel)%s\n",
                b->samplesPerPixel, b->sampleCount(), double(b->sampleCount()) / double(b->pixelCount()), maxSamples,
                b->isFlat() ? ", flat image" : ", OpenEXR deep scanline");
    // The channel list as any OpenEXR reader sees it.
    if (auto in = OIIO::ImageInput::open(path)) {
        const OIIO::ImageSpec& spec = in->spec();
        std::printf("channels:    %d:", spec.nchannels);
        for (int c = 0; c < spec.nchannels; ++c) {
            std::printf(" %s(%s)", spec.channelnames[size_t(c)].c_str(), spec.channelformat(c).c_str());
        }
        std::printf("\n");
    }
    const auto& cam = b->camera;
    if (cam.orthographic) {
        std::printf("camera:      %s, orthographic, ymag %g, aspect %.4f, near %g, far %g\n", cam.name.c_str(),
                    double(cam.ymag), double(cam.aspect), double(cam.znear), double(cam.zfar));
    } else {
        std::printf("camera:      %s, perspective, yfov %.3f deg, aspect %.4f, near %g, far %g\n", cam.name.c_str(),
                    double(cam.yfovRadians) * 57.29577951308232, double(cam.aspect), double(cam.znear), double(cam.zfar));
    }
    const glm::vec3 eye = cam.position(), fwd = cam.forward();
    std::printf("eye:         %g %g %g, looking along %g %g %g\n", double(eye.x), double(eye.y), double(eye.z),
                double(fwd.x), double(fwd.y), double(fwd.z));
    std::printf("source:      %s\n", b->sourcePath.c_str());
    std::printf("sha256:      %s\n", b->sourceSha256.empty() ? "(unknown)" : b->sourceSha256.c_str());
    if (b->hasEnvTransfer()) {
        const char* lobe = b->hasEnvLobe() ? " and specular lobe (env.lobe.*)" : "";
        const int n = b->envBands * b->envBands;
        if (b->envRays > 0)
            std::printf("env:         %d-band SH transfer (env.sh0..%d)%s, %d rays per sample\n", b->envBands, n - 1, lobe, b->envRays);
        else std::printf("env:         %d-band SH transfer (env.sh0..%d)%s, rays per sample not recorded\n", b->envBands, n - 1, lobe);
    } else {
        std::printf("env:         no environment transfer\n");
    }
    if (b->hasHorizon())
        std::printf("horizon:     near-field horizon (horizon.h0..%d), reach %g scene units\n", dfb::HORIZON_AZIMUTHS - 1,
                    double(b->horizonRadius));
    else std::printf("horizon:     no near-field horizon\n");
    std::printf("objects:     %zu\n", b->objectNames.size());
    for (size_t i = 0; i < b->objectNames.size(); ++i) std::printf("  %3zu %s\n", i + 1, b->objectNames[i].c_str());
    std::printf("materials:   %zu\n", b->materialNames.size());
    for (size_t i = 0; i < b->materialNames.size(); ++i) std::printf("  %3zu %s\n", i + 1, b->materialNames[i].c_str());
    return 0;
}

int writeLayer(const std::string& shot, const std::string& layer, const std::string& out) {
    auto b = dfb::readDeepBuffer(shot);
    if (!b) {
        std::cerr << "dfb-bake: " << b.error().toString() << "\n";
        return 2;
    }
    auto pixels = dfb::layerImage(b.value(), layer);
    if (!pixels) {
        std::cerr << "dfb-bake: " << pixels.error().message << "\n";
        return 1;
    }
    auto o = OIIO::ImageOutput::create(out);
    OIIO::ImageSpec spec(b->width, b->height, 3, OIIO::TypeDesc::UINT8);
    if (!o || !o->open(out, spec) || !o->write_image(OIIO::TypeDesc::UINT8, pixels->data()) || !o->close()) {
        std::cerr << "dfb-bake: cannot write " << out << ": " << (o ? o->geterror() : OIIO::geterror()) << "\n";
        return 4;
    }
    std::printf("wrote layer %s of %s to %s\n", layer.c_str(), shot.c_str(), out.c_str());
    return 0;
}

// A progress bar on the terminal (stderr), only when it is one.
void showProgress(size_t done, size_t total) {
    static const bool tty = ::isatty(2);
    if (!tty || total == 0) return;
    const int width = 40, filled = int(width * done / total);
    std::fprintf(stderr, "\r  baking [%.*s%*s] %3d%%", filled, "########################################", width - filled,
                 "", int(100 * done / total));
    if (done == total) std::fprintf(stderr, "\n");
    std::fflush(stderr);
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"dfb-bake: bake a glTF scene into a deep framebuffer (OpenEXR) from a fixed camera"};
    app.set_version_flag("--version",
                         dfb::versionText("dfb-bake") +
                             " (G-buffer format " + std::to_string(dfb::GBUFFER_FORMAT_VERSION) + ")");
    app.footer("Exit codes: 0 ok, 1 bad command line, 2 bad scene/shot/camera, 3 GPU/EGL failure, 4 cannot write.");
    std::string scenePath, outPath, infoPath, layer;
    dfb::BakeOptions opts;
    std::vector<float> lookFrom, lookAt;
    app.add_option("input", scenePath, "glTF scene (.glb or .gltf) to bake, or a baked EXR with --layer");
    app.add_option("-o,--output", outPath, "output EXR path (or image path with --layer)");
    app.add_option("--width", opts.width, "image width in pixels")->check(CLI::Range(1, 16384));
    app.add_option("--height", opts.height, "image height in pixels")->check(CLI::Range(1, 16384));
    app.add_option("--samples", opts.samples, "samples per pixel (anti-aliasing; a square number gives a stratified grid)")
        ->check(CLI::Range(1, dfb::MAX_SAMPLES_PER_PIXEL));
    app.add_option("--camera", opts.cameraName, "glTF camera to bake from (default: the first one, else automatic framing)");
    app.add_option("--look-from", lookFrom, "eye position x,y,z (with --look-at)")->expected(3)->delimiter(',');
    app.add_option("--look-at", lookAt, "target position x,y,z (with --look-from)")->expected(3)->delimiter(',');
    app.add_option("--fov", opts.fovDegrees, "vertical field of view in degrees for --look-from or automatic framing")
        ->check(CLI::Range(1.0, 170.0));
    int envRays = 256;
    app.add_option("--env-rays", envRays,
                   "rays per sample for the environment light's SH visibility transfer and specular lobe (env.sh*, env.lobe.*; 0 = none, at most " +
                       std::to_string(dfb::MAX_ENV_RAYS) + ")")
        ->capture_default_str();
    app.add_option("--env-bands", opts.envBands,
                   "spherical-harmonic bands of the environment transfer: 5 (env.sh0..24) or 3 (env.sh0..8, a smaller file; "
                   "coarser shadows from the environment)")
        ->check(CLI::IsMember({3, 5}))
        ->capture_default_str();
    app.add_option("--horizon-radius", opts.horizonRadius,
                   "reach of each sample's near-field horizon (horizon.h*: contact shadows finer than a shadow map), as a fraction "
                   "of the scene's bounding radius; 0 = none, at most " + std::to_string(dfb::MAX_HORIZON_RADIUS_FRACTION))
        ->check(CLI::Range(0.0, double(dfb::MAX_HORIZON_RADIUS_FRACTION)))
        ->capture_default_str();
    app.add_option("--info", infoPath, "print what a baked EXR holds and exit");
    bool listCamerasOnly = false;
    app.add_flag("--list-cameras", listCamerasOnly, "print the cameras of the scene given as input (name, lens, place) and exit");
    app.add_option("--layer", layer, "write one layer of the baked EXR given as input as a viewable image (-o)");
    if (const int rc = dfb::parseCommandLine(app, argc, argv, "dfb-bake"); rc >= 0) return rc;
    if (envRays < 0 || envRays > dfb::MAX_ENV_RAYS) {
        std::cerr << "dfb-bake: --env-rays " << envRays << " is out of range: 0 (no environment transfer) to "
                  << dfb::MAX_ENV_RAYS << " rays per sample\n";
        return 1;
    }

    if (!infoPath.empty()) return printInfo(infoPath);
    if (listCamerasOnly) {
        if (scenePath.empty()) {
            std::cerr << "dfb-bake: --list-cameras needs a scene: dfb-bake --list-cameras SCENE.glb\n";
            return 1;
        }
        return listCameras(scenePath);
    }
    if (scenePath.empty() || outPath.empty()) {
        std::cerr << "dfb-bake: an input and -o OUTPUT are required (see --help)\n";
        return 1;
    }
    if (!layer.empty()) return writeLayer(scenePath, layer, outPath);
    if (lookFrom.empty() != lookAt.empty()) {
        std::cerr << "dfb-bake: --look-from and --look-at go together\n";
        return 1;
    }
    if (!lookFrom.empty()) {
        opts.lookFrom = glm::vec3(lookFrom[0], lookFrom[1], lookFrom[2]);
        opts.lookAt = glm::vec3(lookAt[0], lookAt[1], lookAt[2]);
    }
    opts.progress = showProgress;
    opts.envRays = envRays;
    dfb::EnvTransferStats envStats;
    opts.envStats = &envStats;
    dfb::HorizonStats horizonStats;
    opts.horizonStats = &horizonStats;

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
    if (envRays > 0) {
        std::printf("environment transfer: %d rays per pixel over %d pass%s, %zu covered samples, %zu rays traced, "
                    "%u threads, %.0f ms of the bake (hierarchy %.0f ms)\n",
                    envRays, opts.samples, opts.samples > 1 ? "es" : "", envStats.samples, envStats.rays,
                    envStats.threads, envStats.totalMs, envStats.bvhMs);
    }
    if (opts.horizonRadius > 0.f) {
        std::printf("near-field horizon: reach %g scene units, %zu covered samples, %zu rays traced, %u threads, %.0f ms\n",
                    double(buffer->horizonRadius), horizonStats.samples, horizonStats.rays, horizonStats.threads,
                    horizonStats.totalMs);
    }
    if (auto s = dfb::writeDeepBuffer(buffer.value(), outPath); !s) {
        std::cerr << "dfb-bake: " << s.error().toString() << "\n";
        return 4;
    }
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    std::printf("baked %s (%zu triangles) -> %s, %dx%d, %d spp (%zu samples stored), camera '%s', %.0f ms\n",
                scenePath.c_str(), scene->triangleCount(), outPath.c_str(), opts.width, opts.height, opts.samples,
                buffer->sampleCount(), buffer->camera.name.c_str(), ms);
    return 0;
}
