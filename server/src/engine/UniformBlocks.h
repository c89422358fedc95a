#pragma once
// std140 uniform blocks shared with the shaders. GLSL mirror: server/shaders/common_uniforms.glsl.
// Every offset is pinned so that a change on one side fails the build until the other follows.

#include <glm/glm.hpp>

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
    TEX_PIXEL_SAMPLES = 8,
    TEX_GBUFFER_SHEEN = 9,
    TEX_GBUFFER_COAT = 10,
};
enum UniformBinding : unsigned { UBO_LIGHT = 0, UBO_VIEW = 1 };

struct LightBlock {
    glm::mat4 worldToLightClip;
    glm::vec4 lightPosition;
    glm::vec4 lightAxis;
    glm::vec4 lightRadiance;
    glm::vec4 lightCone;
    glm::vec4 lightShadow;
};
static_assert(offsetof(LightBlock, worldToLightClip) == 0);
static_assert(offsetof(LightBlock, lightPosition) == 64);
static_assert(offsetof(LightBlock, lightAxis) == 80);
static_assert(offsetof(LightBlock, lightRadiance) == 96);
static_assert(offsetof(LightBlock, lightCone) == 112);
static_assert(offsetof(LightBlock, lightShadow) == 128);
static_assert(sizeof(LightBlock) == 144);

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

} // namespace dfb::engine
