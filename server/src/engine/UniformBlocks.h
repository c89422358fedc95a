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
    glm::ivec4 sampleLayout;  // x = width of the sample textures
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
    // Per segment, the capsule around its chord that holds its tube (segmentCapsuleContains):
    glm::vec4 capsuleStart[lightmath::MAX_SEGMENTS]; // xyz p0, w reach^2
    glm::vec4 capsuleChord[lightmath::MAX_SEGMENTS]; // xyz p2 - p0, w 1 / |p2 - p0|^2
};
static_assert(lightmath::MAX_CONTROL_POINTS == 17 && lightmath::MAX_SEGMENTS == 8,
              "BENDY_MAX_POINTS / BENDY_MAX_SEGMENTS in common_bendy.glsl must follow");
static_assert(offsetof(BendyBlock, c) == 17 * 16);
static_assert(offsetof(BendyBlock, frameV) == 34 * 16);
static_assert(offsetof(BendyBlock, axisU) == 43 * 16);
static_assert(offsetof(BendyBlock, end) == 46 * 16);
static_assert(offsetof(BendyBlock, capsuleStart) == 47 * 16);
static_assert(sizeof(BendyBlock) == 63 * 16);

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
        // A quadratic Bezier stays within |2 p1 - p0 - p2| / 4 of its chord (B(t) - chord(t) =
        // t (1 - t) (2 p1 - p0 - p2)); the tube within the largest control radius of the curve
        // (convex hull); grown by 1% against rounding.
        const glm::vec3 p0 = ch.p[2 * k], p1 = ch.p[2 * k + 1], p2 = ch.p[2 * k + 2];
        const float reach = (0.25f * glm::length(2.f * p1 - p0 - p2) + std::max({ch.r[2 * k], ch.r[2 * k + 1], ch.r[2 * k + 2]})) * 1.01f + 1e-3f;
        const glm::vec3 chord = p2 - p0;
        b.capsuleStart[k] = glm::vec4(p0, reach * reach);
        b.capsuleChord[k] = glm::vec4(chord, 1.f / std::max(glm::dot(chord, chord), 1e-30f));
    }
    return b;
}

} // namespace dfb::engine
