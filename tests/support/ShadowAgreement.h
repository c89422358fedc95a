#pragma once
// Test support: an engine's shadow mask against ray-traced hard shadows (Embree), pixel by pixel
// over the pixels the light reaches fully, lit where the mask's filtered visibility >= 0.5 (issue
// 16 point 3). Shared by engine_shadow_bias_test and dfb-fidelity-bench.

#include "support/RayCaster.h"

#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/protocol/Rig.h>
#include <dfb/server/Engine.h>

#include <glm/glm.hpp>

namespace dfb::test {

/// Lit/shadowed counts of the engine against the reference.
struct ShadowCounts {
    size_t reached = 0, agree = 0, shadowedEngine = 0, shadowedRef = 0;
    size_t litHereShadowedRef = 0, shadowedHereLitRef = 0;
    void add(bool lit, bool refLit) {
        ++reached;
        agree += lit == refLit;
        shadowedEngine += !lit;
        shadowedRef += !refLit;
        litHereShadowedRef += lit && !refLit;
        shadowedHereLitRef += !lit && refLit;
    }
    double agreement() const { return reached ? double(agree) / double(reached) : 0.0; }
    double areaRatio() const { return shadowedRef ? double(shadowedEngine) / double(shadowedRef) : 1.0; }
};

/// How far rays leave the surface (against self-intersection from the stored positions'
/// rounding): far below a shadow-map texel of a scene of bounding radius `radius`.
inline float rayHair(float radius) { return 1e-5f * radius; }

/// Whether a straight light (spot, point, directional, a straight BendyLight as its spot) reaches
/// the receiver at P (geometric normal Ng) unoccluded; `radius`: the scene's bounding radius.
inline bool rayTracedLit(const RayCaster& rays, const Light& light, const glm::vec3& P, const glm::vec3& Ng, float radius) {
    const glm::vec3 from = P + Ng * rayHair(radius);
    if (light.type == LightType::Directional) {
        const glm::vec3 towardsSun = -glm::normalize(glm::vec3(light.direction[0], light.direction[1], light.direction[2]));
        return !rays.occluded(from, P + towardsSun * (4.f * radius), 1e-6f);
    }
    return !rays.occluded(from, glm::vec3(light.position[0], light.position[1], light.position[2]), 1e-6f);
}

/// Calls fn(pixel, sample, visibility) for every pixel of `g` that `mask` (Engine::renderShadowMask:
/// r = coverage-weighted visibility, g = coverage) says the light reaches fully, with the pixel's
/// first sample and its filtered visibility.
template <class F>
void forEachReachedPixel(const ImageF& mask, const DeepBuffer& g, F&& fn) {
    for (int y = 0; y < g.height; ++y)
        for (int x = 0; x < g.width; ++x) {
            const size_t p = size_t(y) * size_t(g.width) + size_t(x);
            if (g.pixelSamples(x, y) == 0 || mask.rgba[p * 4 + 1] < 0.999f) continue; // not (fully) reached
            fn(p, g.firstSample(x, y), mask.rgba[p * 4] / mask.rgba[p * 4 + 1]);
        }
}

/// The light alone's shadow mask against rayTracedLit (straight lights).
inline Result<ShadowCounts> straightShadowAgreement(Engine& engine, const DeepBuffer& g, const RayCaster& rays,
                                                    const Light& light, float radius) {
    Rig rig;
    rig.lights = {light};
    auto mask = engine.renderShadowMask(rig, light.name);
    if (!mask) return mask.error();
    ShadowCounts n;
    forEachReachedPixel(mask.value(), g, [&](size_t, size_t s, float vis) {
        const glm::vec3 Ng(g.Ng[s * 3], g.Ng[s * 3 + 1], g.Ng[s * 3 + 2]);
        n.add(vis >= 0.5f, rayTracedLit(rays, light, g.position(s), Ng, radius));
    });
    return n;
}

} // namespace dfb::test
