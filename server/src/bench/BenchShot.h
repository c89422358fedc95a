#pragma once
// The benchmarks' common start: a shot, its scene's shadow casters and an engine over them.

#include <dfb/gbuffer/ExrIO.h>
#include <dfb/gbuffer/Scene.h>
#include <dfb/server/Engine.h>

#include <iostream>
#include <memory>
#include <string>

namespace dfb::bench {

struct BenchShot {
    DeepBuffer shot;
    Scene scene;
    ShadowGeometry casters;
    std::unique_ptr<Engine> engine;
};

/// Reads the shot, loads `scenePath` (empty: the shot's source scene) and makes an engine. Returns
/// 0, or the exit code after printing why as `program: message`: 2 for unreadable input, 3 when
/// the engine cannot start.
inline int openBenchShot(const char* program, const std::string& shotPath, const std::string& scenePath, BenchShot& out) {
    auto shot = readDeepBuffer(shotPath);
    if (!shot) {
        std::cerr << program << ": " << shot.error().toString() << "\n";
        return 2;
    }
    auto scene = loadScene(scenePath.empty() ? shot->sourcePath : scenePath);
    if (!scene) {
        std::cerr << program << ": " << scene.error().toString() << "\n";
        return 2;
    }
    out.shot = std::move(shot.value());
    out.scene = std::move(scene.value());
    out.casters = shadowCasters(out.scene);
    auto engine = Engine::create(out.shot, out.casters);
    if (!engine) {
        std::cerr << program << ": " << engine.error().toString() << "\n";
        return 3;
    }
    out.engine = std::move(engine.value());
    return 0;
}

} // namespace dfb::bench
