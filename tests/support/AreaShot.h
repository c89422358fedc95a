#pragma once
// A small flat-baked shot for the area light tests (tests/gpu/area_light_test.cpp,
// bent_area_light_test.cpp): an 8 x 8 ground and, optionally, a box standing on it, with the engine
// over its casters and Embree rays against the same meshes.

#include "support/FlatMesh.h"
#include "support/RayCaster.h"

#include <dfb/gbuffer/Baker.h>
#include <dfb/protocol/Codec.h>
#include <dfb/server/Engine.h>

#include <gtest/gtest.h>

#include <glm/gtc/packing.hpp>

#include <algorithm>
#include <cmath>
#include <memory>

namespace dfb::test {

constexpr int WIDTH = 160, HEIGHT = 120;

// A ground 8 x 8 at y = 0 and a 0.6-unit box standing on it (its five visible faces), seen from
// above and in front.
struct Shot {
    Scene scene;
    DeepBuffer g;
    std::unique_ptr<Engine> engine;
    test::RayCaster rays;
};

// Bakes s.scene at WIDTH x HEIGHT, makes the engine over its casters and the reference rays.
inline void finishShot(Shot& s, BakeOptions o) {
    o.width = WIDTH;
    o.height = HEIGHT;
    auto b = bake(s.scene, o);
    ASSERT_TRUE(b.ok()) << b.error().toString();
    s.g = std::move(b.value());
    auto e = Engine::create(s.g, shadowCasters(s.scene));
    ASSERT_TRUE(e.ok()) << e.error().toString();
    s.engine = std::move(e.value());
    for (const MeshPart& p : s.scene.parts) s.rays.addMesh(p.positions, p.indices);
    s.rays.commit();
}

/// What makeShot builds: the box's corners (none when `box` is false), the one material's
/// terms, and the bake's environment rays (BakeOptions::envRays).
struct ShotOptions {
    bool box = true;
    glm::vec3 boxMin{-0.3f, 0.f, -0.3f}, boxMax{0.3f, 0.6f, 0.3f};
    float metallic = 0.f, roughness = 0.5f;
    float specularFactor = 1.f; ///< KHR_materials_specular: 0 = Lambert
    int envRays = 0;
};

inline void makeShot(Shot& s, const ShotOptions& opt) {
    if (s.scene.materials.empty()) s.scene.materials.push_back(Material{});
    s.scene.materials[0].metallic = opt.metallic;
    s.scene.materials[0].roughness = opt.roughness;
    s.scene.materials[0].specularFactor = opt.specularFactor;
    s.scene.materials[0].baseColor = glm::vec4(0.8f, 0.8f, 0.8f, 1.f);
    s.scene.objectNames = {"ground", "box"};
    std::vector<glm::vec3> g;
    quad(g, {-4, 0, 4}, {4, 0, 4}, {4, 0, -4}, {-4, 0, -4});
    s.scene.parts.push_back(flatPart(1, g));
    if (opt.box) {
        std::vector<glm::vec3> c;
        const glm::vec3 a = opt.boxMin, b = opt.boxMax;
        quad(c, {a.x, b.y, b.z}, {b.x, b.y, b.z}, {b.x, b.y, a.z}, {a.x, b.y, a.z});
        quad(c, {a.x, a.y, b.z}, {b.x, a.y, b.z}, {b.x, b.y, b.z}, {a.x, b.y, b.z});
        quad(c, {b.x, a.y, a.z}, {a.x, a.y, a.z}, {a.x, b.y, a.z}, {b.x, b.y, a.z});
        quad(c, {b.x, a.y, b.z}, {b.x, a.y, a.z}, {b.x, b.y, a.z}, {b.x, b.y, b.z});
        quad(c, {a.x, a.y, a.z}, {a.x, a.y, b.z}, {a.x, b.y, b.z}, {a.x, b.y, a.z});
        s.scene.parts.push_back(flatPart(2, c));
    }
    for (const MeshPart& p : s.scene.parts)
        for (const glm::vec3& v : p.positions) s.scene.bounds.extend(v);
    BakeOptions o;
    o.lookFrom = glm::vec3(0.f, 4.f, 4.5f);
    o.lookAt = glm::vec3(0.f, 0.f, 0.f);
    o.fovDegrees = 50.f;
    o.envRays = opt.envRays;
    finishShot(s, o);
}

inline void makeShot(Shot& s, bool withBox, float metallic = 0.f, float roughness = 0.5f) {
    ShotOptions o;
    o.box = withBox;
    o.metallic = metallic;
    o.roughness = roughness;
    makeShot(s, o);
}

inline Light panel(const char* name, float height, bool disk) {
    Light l;
    l.name = name;
    l.type = LightType::Area;
    l.position = {0.2f, height, 0.1f};
    l.direction = {0.f, -1.f, 0.f};
    l.areaShape = disk ? AreaShape::Disk : AreaShape::Rect;
    l.areaSize = {1.5f, 1.f};
    l.rollDeg = 20.f;
    l.intensityCd = 1.f;
    l.shadowMapSize = 512;
    l.alphaBeta = {0.55f, 3.2f};
    return l;
}

// Per pixel (one sample each: a flat bake), the C++ value of `f` at the pixel's sample.
template <class F> void forEachSample(const DeepBuffer& g, F&& fn) {
    for (int y = 0; y < g.height; ++y)
        for (int x = 0; x < g.width; ++x) {
            if (g.pixelSamples(x, y) != 1) continue;
            const size_t s = g.firstSample(x, y);
            if (g.A[s] < 0.999f) continue;
            fn(size_t(y) * size_t(g.width) + size_t(x), s);
        }
}

struct Errors {
    double sumAbs = 0, sumRef = 0, maxRel = 0;
    size_t n = 0;
    void add(double got, double want) {
        sumAbs += std::abs(got - want);
        sumRef += std::abs(want);
        if (want > 1e-3) maxRel = std::max(maxRel, std::abs(got - want) / want);
        ++n;
    }
    double meanRel() const { return sumRef > 0 ? sumAbs / sumRef : 0; }
};

/// What the engine shades sample `s` with, as the C++ mirrors need it: the engine's G-buffer
/// textures hold normals, albedo and BRDF terms as half floats (rounded here the same way).
struct SampleInputs {
    glm::dvec3 P, N, V, albedo;
    double metallic = 0, roughness = 0, specular = 0;
};
inline SampleInputs sampleInputs(const DeepBuffer& g, size_t s) {
    auto half = [](float v) { return double(glm::unpackHalf1x16(glm::packHalf1x16(v))); };
    SampleInputs in;
    in.P = glm::dvec3(g.position(s));
    in.N = glm::normalize(glm::dvec3(half(g.N[s * 3]), half(g.N[s * 3 + 1]), half(g.N[s * 3 + 2])));
    in.V = glm::normalize(glm::dvec3(g.camera.position()) - in.P);
    in.albedo = glm::dvec3(half(g.albedo[s * 3]), half(g.albedo[s * 3 + 1]), half(g.albedo[s * 3 + 2]));
    in.metallic = half(g.brdf[s * 4]);
    in.roughness = half(g.brdf[s * 4 + 1]);
    in.specular = half(g.brdf[s * 4 + 2]);
    return in;
}

/// `path` = `v` is refused on `rig` with a message holding `words`, and the rig is unchanged.
inline void expectRefused(const Rig& rig, const char* path, const nlohmann::json& v, const char* words) {
    Rig r = rig;
    Status s = protocol::applyChanges(r, {{path, v}});
    ASSERT_FALSE(s.ok()) << path;
    EXPECT_NE(s.error().message.find(words), std::string::npos) << s.error().message;
    EXPECT_EQ(protocol::toJson(r), protocol::toJson(rig)); // nothing changed
}

} // namespace dfb::test
