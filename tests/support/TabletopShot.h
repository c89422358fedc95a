#pragma once
// Test support: the bundled default scene (scenes/tabletop.glb) baked from its camera at a given
// size and sample count, and an engine made from that bake with the scene's shadow casters (the
// set-up of the engine tests that relight the tabletop). Exactly loadScene, bake and
// Engine::create(shot, shadowCasters(scene)): the golden frames depend on it. No GoogleTest
// here: failures are Results.

#include <dfb/gbuffer/Baker.h>
#include <dfb/gbuffer/Scene.h>
#include <dfb/server/Engine.h>

#include <memory>
#include <utility>

namespace dfb::test {

/// The scene and its bake.
struct TabletopShot {
    Scene scene;
    DeepBuffer shot;
};

/// Loads scenes/tabletop.glb and bakes it at width x height with `samples` per pixel.
inline Result<TabletopShot> bakeTabletop(int width, int height, int samples = 1) {
    auto scene = loadScene(DFB_SOURCE_DIR "/scenes/tabletop.glb");
    if (!scene) return scene.error();
    BakeOptions o;
    o.width = width;
    o.height = height;
    o.samples = samples;
    auto shot = bake(scene.value(), o);
    if (!shot) return shot.error();
    return TabletopShot{std::move(scene.value()), std::move(shot.value())};
}

/// The scene, its bake, its shadow casters and an engine made from both (its GL context current
/// on the calling thread; the engine holds copies, not references).
struct TabletopEngine {
    Scene scene;
    DeepBuffer shot;
    ShadowGeometry casters;
    std::unique_ptr<Engine> engine;
};

/// bakeTabletop, then Engine::create(shot, shadowCasters(scene)).
inline Result<TabletopEngine> tabletopEngine(int width, int height, int samples = 1) {
    auto baked = bakeTabletop(width, height, samples);
    if (!baked) return baked.error();
    TabletopEngine t{std::move(baked->scene), std::move(baked->shot), {}, nullptr};
    t.casters = shadowCasters(t.scene);
    auto engine = Engine::create(t.shot, t.casters);
    if (!engine) return engine.error();
    t.engine = std::move(engine.value());
    return t;
}

} // namespace dfb::test
