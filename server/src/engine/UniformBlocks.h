#pragma once
// std140 uniform blocks shared with the shaders. GLSL mirror: server/shaders/common_uniforms.glsl.
// Every offset is pinned so that a change on one side fails the build until the other follows.

#include <dfb/lightmath/BendyLight.h>

#include <glm/glm.hpp>

#include <algorithm>
#include <cstddef>

namespace dfb::engine {

// Texture units, as the #defines of common_uniforms.glsl.
enum TextureUnit : unsigned {
    TEX_GBUFFER_P = 0,
    TEX_GBUFFER_N = 1,
    TEX_GBUFFER_NG = 2,
    TEX_GBUFFER_ALBEDO = 3,
    TEX_GBUFFER_BRDF = 4,
    TEX_GBUFFER_EMISSION = 5,
    TEX_SHADOW_MAP = 6,
    TEX_INPUT = 7,
    TEX_INPUT_HOT = 14,
    TEX_PIXEL_SAMPLES = 8,
    TEX_GBUFFER_SHEEN = 9,
    TEX_GBUFFER_COAT = 10,
    TEX_GBUFFER_ID = 11,
    TEX_SHADOW_CUBE = 12,
    TEX_COOKIE = 13,
    TEX_DEFORMED = 15,
    TEX_CASTER_INDICES = 16,
};
enum StorageBinding : unsigned { SSBO_LINK_MASK = 6 };
enum UniformBinding : unsigned { UBO_LIGHT = 0, UBO_VIEW = 1, UBO_BENDY = 2 };

struct LightBlock {
    glm::mat4 worldToLightClip;
    glm::vec4 lightPosition;
    glm::vec4 lightAxis;
    glm::vec4 lightRadiance;
    glm::vec4 lightCone;
    glm::vec4 lightShadow;
    glm::vec4 lightRight;
    glm::vec4 lightUp;
    glm::vec4 lightDoors;
    glm::vec4 lightCube;
};
static_assert(offsetof(LightBlock, worldToLightClip) == 0);
static_assert(offsetof(LightBlock, lightPosition) == 64);
static_assert(offsetof(LightBlock, lightAxis) == 80);
static_assert(offsetof(LightBlock, lightRadiance) == 96);
static_assert(offsetof(LightBlock, lightCone) == 112);
static_assert(offsetof(LightBlock, lightShadow) == 128);
static_assert(offsetof(LightBlock, lightRight) == 144);
static_assert(offsetof(LightBlock, lightUp) == 160);
static_assert(offsetof(LightBlock, lightDoors) == 176);
static_assert(offsetof(LightBlock, lightCube) == 192);
static_assert(sizeof(LightBlock) == 208);

struct ViewBlock {
    glm::vec4 cameraPosition; // w = 1 if orthographic
    glm::vec4 cameraForward;
    glm::vec4 exposure;
    glm::ivec4 sampleLayout;  // x = width of the sample textures, y = log2 of it (deep buffers: a power of two)
};
static_assert(offsetof(ViewBlock, cameraForward) == 16);
static_assert(offsetof(ViewBlock, exposure) == 32);
static_assert(offsetof(ViewBlock, sampleLayout) == 48);
static_assert(sizeof(ViewBlock) == 64);

/// A BendyLight's chain. GLSL mirror: BendyBlock in server/shaders/common_bendy.glsl.
struct BendyBlock {
    glm::vec4 p[lightmath::MAX_CONTROL_POINTS];      // xyz control point, w radius
    glm::vec4 c[lightmath::MAX_CONTROL_POINTS];      // rgb colour
    glm::vec4 frameV[lightmath::MAX_SEGMENTS + 1];   // xyz v_hat at segment start, w arc length there
    glm::vec4 axisU;                                 // w tan(theta)
    glm::vec4 axisV;                                 // w number of segments
    glm::vec4 axisW;                                 // w 1 = exact light direction
    glm::vec4 end;                                   // xyz end tangent, w end radius slope
    // Per segment, the round cone around its chord that holds its tube (segmentFootprintContains):
    glm::vec4 coneStart[lightmath::MAX_SEGMENTS]; // xyz p0, w radius at p0
    glm::vec4 coneChord[lightmath::MAX_SEGMENTS]; // xyz p2 - p0, w 1 / |p2 - p0|^2
    glm::vec4 coneRadius[lightmath::MAX_SEGMENTS];  // x radius at p2 - radius at p0, y slope term m
};
static_assert(lightmath::MAX_CONTROL_POINTS == 17 && lightmath::MAX_SEGMENTS == 8,
              "BENDY_MAX_POINTS / BENDY_MAX_SEGMENTS in common_bendy.glsl must follow");
static_assert(offsetof(BendyBlock, c) == 17 * 16);
static_assert(offsetof(BendyBlock, frameV) == 34 * 16);
static_assert(offsetof(BendyBlock, axisU) == 43 * 16);
static_assert(offsetof(BendyBlock, end) == 46 * 16);
static_assert(offsetof(BendyBlock, coneStart) == 47 * 16);
static_assert(offsetof(BendyBlock, coneRadius) == 63 * 16);
static_assert(sizeof(BendyBlock) == 71 * 16);

inline BendyBlock toBendyBlock(const lightmath::Chain<float>& ch, bool exactDirection) {
    BendyBlock b{};
    for (int i = 0; i <= 2 * ch.segments; ++i) {
        b.p[i] = glm::vec4(ch.p[i], ch.r[i]);
        b.c[i] = glm::vec4(ch.c[i], 1.f);
    }
    for (int k = 0; k <= ch.segments; ++k) b.frameV[k] = glm::vec4(ch.frameV[k], ch.arcStart[k]);
    b.axisU = glm::vec4(ch.axisU, ch.tanTheta);
    b.axisV = glm::vec4(ch.axisV, float(ch.segments));
    b.axisW = glm::vec4(ch.axisW, exactDirection ? 1.f : 0.f);
    b.end = glm::vec4(ch.endTangent, ch.endRadiusSlope);
    for (int k = 0; k < ch.segments; ++k) {
        // The tube around segment k lies in the round cone along its chord p0 p2 (the balls of
        // radius (1 - t) r0' + t r2' around chord(t), t in [0, 1]): B(t) = chord(t) + t (1 - t) W,
        // R(t) = (1 - t) r0 + t r2 + t (1 - t) (2 r1 - r0 - r2), W = 2 p1 - p0 - p2, so a point
        // within R(t) of B(t) is within (1 - t) r0 + t r2 + max(0, 2 r1 - r0 - r2 + |W|) / 4 of
        // chord(t); grown by 1% against rounding. Its least distance over t is convex in t: the
        // shader clamps the stationary point h* = along + m |off| (m below; L = |p2 - p0|,
        // dr = r2' - r0') to [0, 1]; where |dr| >= L the least lies at an end (m = +-inf).
        const glm::vec3 p0 = ch.p[2 * k], p1 = ch.p[2 * k + 1], p2 = ch.p[2 * k + 2];
        const float r0 = ch.r[2 * k], r1 = ch.r[2 * k + 1], r2 = ch.r[2 * k + 2];
        const float bulge = 0.25f * std::max(0.f, 2.f * r1 - r0 - r2 + glm::length(2.f * p1 - p0 - p2));
        const float ra = (r0 + bulge) * 1.01f + 1e-3f, rb = (r2 + bulge) * 1.01f + 1e-3f;
        const glm::vec3 chord = p2 - p0;
        const float L2 = glm::dot(chord, chord), dr = rb - ra;
        const float m = L2 - dr * dr > 1e-12f * std::max(L2, 1e-30f) ? dr / (std::sqrt(L2) * std::sqrt(L2 - dr * dr))
                                                                    : (dr >= 0.f ? 1e30f : -1e30f);
        b.coneStart[k] = glm::vec4(p0, ra);
        b.coneChord[k] = glm::vec4(chord, 1.f / std::max(L2, 1e-30f));
        b.coneRadius[k] = glm::vec4(dr, m, 0.f, 0.f);
    }
    return b;
}

} // namespace dfb::engine
