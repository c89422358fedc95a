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
struct ShadowTally {
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

/// Receivers that face the light by more than this cosine (N_g . L; 84 degrees from it): a map
/// texel's footprint on a receiver at grazing incidence spans 1 / (N_g . L) texels of depth, so
/// occluders closer than that along the ray (a curved mesh's own facets near its terminator) are
/// below any shadow map's resolution, whatever its bias (docs/lighting.md, Shadows). These
/// receivers get 1 / (N_g . L) < 10 % of the light's full-on radiance.
constexpr float FACING_COSINE = 0.1f;

/// Over all reached pixels, and over those whose receiver faces the light (FACING_COSINE).
struct ShadowCounts : ShadowTally {
    ShadowTally facing;
    void add(bool lit, bool refLit, float cosine = 1.f) {
        ShadowTally::add(lit, refLit);
        if (cosine >= FACING_COSINE) facing.add(lit, refLit);
    }
};

/// How far rays leave the surface (against self-intersection from the stored positions'
/// rounding): far below a shadow-map texel of a scene of bounding radius `radius`.
inline float rayHair(float radius) { return 1e-5f * radius; }

/// The unit direction from P towards a straight light.
inline glm::vec3 towardsLight(const Light& light, const glm::vec3& P) {
    if (light.type == LightType::Directional)
        return -glm::normalize(glm::vec3(light.direction[0], light.direction[1], light.direction[2]));
    return glm::normalize(glm::vec3(light.position[0], light.position[1], light.position[2]) - P);
}

/// Whether a straight light (spot, point, directional, a straight BendyLight as its spot) reaches
/// the receiver at P (geometric normal Ng) unoccluded; `radius`: the scene's bounding radius.
/// A facet whose geometric normal faces away from the light is shadowed by itself: the light
/// would reach P from behind its own surface (inside a closed mesh). The ray from P + hair Ng
/// alone gets that wrong: leaving the front side it crosses the facet's plane a hair's length /
/// |Ng.L| away, often past the facet's edge, and escapes (on the Stanford dragon 8-13 such
/// terminator pixels per light were "lit in the reference"; the engine's rule, shadowVisibility
/// in relight_spot.frag, is this one).
inline bool rayTracedLit(const RayCaster& rays, const Light& light, const glm::vec3& P, const glm::vec3& Ng, float radius) {
    const glm::vec3 L = towardsLight(light, P);
    if (glm::dot(Ng, L) <= 0.f) return false;
    const glm::vec3 from = P + Ng * rayHair(radius);
    if (light.type == LightType::Directional) return !rays.occluded(from, P + L * (4.f * radius), 1e-6f);
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
        const glm::vec3 P = g.position(s);
        n.add(vis >= 0.5f, rayTracedLit(rays, light, P, Ng, radius), glm::dot(Ng, towardsLight(light, P)));
    });
    return n;
}

} // namespace dfb::test
