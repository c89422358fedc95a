#pragma once
// The interface between the engine's C++ and its shaders, written once: texture units, storage-
// and uniform-block bindings, every uniform location, the stage interface, the limits the shaders
// size arrays with, and the std140 blocks. The numbers are X-macro tables; the build runs
// main_gpu_interface.cpp, which prints them as the #defines of the generated
// common_gpu_interface.glsl that the shaders include (through common_uniforms.glsl and
// common_bendy.glsl), so no binding or location is written on both sides (filament's
// UibStructs.h and EngineEnums.h). The blocks' GLSL mirrors are common_uniforms.glsl and
// common_bendy.glsl; every offset is pinned so that a change on one side fails the build until
// the other follows.
//
// A table row is X(NAME, value, "what"): the C++ gets an enumerator NAME = value, the GLSL
// `#define NAME value // what`. This header includes no GL (the generator is a plain program).

#include <dfb/lightmath/BendyLight.h>
#include <dfb/lightmath/Environment.h>
#include <dfb/lightmath/Horizon.h>
#include <dfb/lightmath/Ltc.h>

#include <glm/glm.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>

// Texture units (glBindTextureUnit; layout(binding = TEX_...) on samplers). G-buffer samples live
// in 2D "sample textures" of width SAMPLE_ROW (uView.sampleLayout.x): sample s is the texel
// (s % SAMPLE_ROW, s / SAMPLE_ROW) (sampleTexel in common_uniforms.glsl).
#define DFB_GPU_TEXTURE_UNITS(X)                                                                          \
    X(TEX_GBUFFER_P, 0, "RGBA32F: world position xyz, coverage A in w")                                   \
    X(TEX_GBUFFER_N, 1, "RGBA16F: shading normal xyz")                                                    \
    X(TEX_GBUFFER_NG, 2, "RGBA16F: geometric normal xyz, w the highest near-field horizon sine (0 without one)") \
    X(TEX_GBUFFER_ALBEDO, 3, "RGBA16F: albedo rgb")                                                       \
    X(TEX_GBUFFER_BRDF, 4, "RGBA16F: metallic, roughness, specular, occlusion")                          \
    X(TEX_GBUFFER_EMISSION, 5, "RGBA16F: emission rgb")                                                   \
    X(TEX_SHADOW_MAP, 6, "DEPTH32F, raw depths (receiver-plane comparison in the shader)")                \
    X(TEX_INPUT, 7, "generic input of composite passes")                                                  \
    X(TEX_PIXEL_SAMPLES, 8, "RG32UI per pixel: first sample, sample count")                              \
    X(TEX_GBUFFER_SHEEN, 9, "RGBA16F: sheen rgb, sheen roughness")                                        \
    X(TEX_GBUFFER_COAT, 10, "RG16F: coat weight, coat roughness")                                         \
    X(TEX_GBUFFER_ID, 11, "R32UI: object id (light linking)")                                             \
    X(TEX_SHADOW_CUBE, 12, "DEPTH32F cube map, raw depths (point lights)")                               \
    X(TEX_COOKIE, 13, "RGBA16F: a spot light's cookie image")                                             \
    X(TEX_INPUT_HOT, 14, "composite_tonemap.frag's second input (the edited light)")                     \
    X(TEX_DEFORMED, 15, "buffer texture RGBA32F: bendy_deform.comp's output, 2 texels per caster vertex") \
    X(TEX_CASTER_INDICES, 16, "buffer texture R32UI: the caster triangles' vertex indices")              \
    X(TEX_AREA_PATTERN, 17, "RGBA32F: an area light's pattern as a summed-area table, mean removed")      \
    X(TEX_SHADOW_ARRAY, 18, "DEPTH32F 2D array, raw depths: an area light's grid of shadow maps")        \
    X(TEX_LTC_MATRIX, 19, "RGBA32F LTC_SIZE^2: the fitted LTC's M^-1 (a, b, c, d) per (roughness, sqrt(1 - N.v)) (Ltc.h)") \
    X(TEX_LTC_AMPLITUDE, 20, "RG32F LTC_SIZE^2: the fitted lobe's norm and Schlick share (Ltc.h)")   \
    X(TEX_ENV_PREFILTERED, 21, "RGBA32F cube map, ENV_LEVELS mips: an environment light's map prefiltered by GGX roughness level / (ENV_LEVELS - 1)") \
    X(TEX_ENV_DFG, 22, "RG32F ENV_DFG_SIZE^2: the split sum's (A, B) by (N.v, roughness) (Environment.h dfgTable)") \
    X(TEX_GBUFFER_ENV, 23, "RGBA16F 2D array: the baked environment transfer T_0..T_{n-1} (DeepBuffer::envTransfer, n = envBands^2) then the specular lobe (DeepBuffer::envLobe) u, v, share, four per layer") \
    X(TEX_ENV_IRRADIANCE, 26, "RGBA32F ENV_IRRADIANCE_WIDTH x /2 lat-long of normals in the map's frame: its exact E(N) / pi less the order-3 expansion (envIrradianceMap)") \
    X(TEX_GBUFFER_HORIZON, 27, "RGBA16F 2D array: the near-field horizon's sines (DeepBuffer::horizon), azimuth k at layer k / 4, component k % 4") \
    X(TEX_ENV_SUN_MAPS, 28, "DEPTH32F, raw depths: an environment light's suns' shadow maps, sun k at unit TEX_ENV_SUN_MAPS + k (ENV_SUN_SLOTS units)")

// Shader storage buffers (glBindBufferBase(GL_SHADER_STORAGE_BUFFER); layout(std430, binding)).
#define DFB_GPU_STORAGE_BINDINGS(X)                                                                    \
    X(SSBO_CASTER_POSITIONS, 0, "bendy_deform.comp's input: the casters' vertices, xyz floats")        \
    X(SSBO_DEFORMED, 1, "bendy_deform.comp's output (read back as TEX_DEFORMED)")                     \
    X(SSBO_FLAT_INDICES, 3, "bendy_classify.comp's triangles for the plain draws")                    \
    X(SSBO_TESS_INDICES, 4, "bendy_classify.comp's triangles for the tessellated draws")              \
    X(SSBO_DRAW_COMMANDS, 5, "BendyDrawCommands: the deformed map's four indirect draws")             \
    X(SSBO_LINK_MASK, 6, "per light: bit (id % 32) of word (id / 32) set = the object is lit")

// Uniform blocks (glBindBufferBase(GL_UNIFORM_BUFFER); layout(std140, binding)).
#define DFB_GPU_UNIFORM_BLOCKS(X)                                                  \
    X(UBO_LIGHT, 0, "LightBlock: the light being rendered or shaded")             \
    X(UBO_VIEW, 1, "ViewBlock: the shot's camera, exposure and sample layout")    \
    X(UBO_BENDY, 2, "BendyBlock: a BendyLight's chain")                          \
    X(UBO_ENV_SH, 3, "EnvShBlock: an environment light's radiance as 25 vec4 (rgb L_i of the turned map, five bands; SphericalHarmonics.h)") \
    X(UBO_AREA_LAYERS, 4, "AreaLayers: an area light's shadow layers, AREA_MAX_LAYERS vec4(clip-space x, y offset of the layer's eye, its emitter coordinates along right, up)") \
    X(UBO_ENV_SUNS, 5, "EnvSunBlock: the suns taken out of an environment light's map, shaded in its pass")

// Uniform locations (glUniform*; layout(location) uniform), per program: relight_spot.frag,
// relight_bendy.frag and relight_mask.frag (RELIGHT), composite_add.frag and
// composite_tonemap.frag (COMPOSITE), bendy_deform.comp (DEFORM), bendy_classify.comp (CLASSIFY),
// shadow_bendy.tesc (TESS).
#define DFB_GPU_UNIFORM_LOCATIONS(X)                                                                   \
    X(LOC_RELIGHT_OUTPUT, 0, "int: 0 the light's radiance, 1 its shadow mask")                         \
    X(LOC_RELIGHT_LINKED, 1, "int: 1 when the light has include/exclude lists (SSBO_LINK_MASK)")       \
    X(LOC_RELIGHT_PIXEL_STEP, 2, "int: 1, or 2 for a half-resolution preview")                        \
    X(LOC_COMPOSITE_SCALE, 0, "vec3: current colour x intensity / the one the input was shaded with") \
    X(LOC_COMPOSITE_PIXEL_STEP, 1, "int: the input's pixel step (2: a preview contribution)")          \
    X(LOC_DEFORM_VERTEX_COUNT, 0, "uint: caster vertices")                                             \
    X(LOC_CLASSIFY_TRIANGLE_COUNT, 0, "uint: triangles to sort")                                       \
    X(LOC_CLASSIFY_MAX_LEVEL, 1, "float: the subdivision limit")                                       \
    X(LOC_CLASSIFY_TEXEL_PER_DISTANCE, 2, "float: shadow-map texel size at unit distance")             \
    X(LOC_CLASSIFY_CLOSED_TRIANGLES, 3, "uint: the first this many are closed meshes'")                \
    X(LOC_TESS_MAX_LEVEL, 0, "float: the subdivision limit (1 = none)")                               \
    X(LOC_TESS_TEXEL_PER_DISTANCE, 1, "float: shadow-map texel size at unit distance")

// Vertex attributes and fragment outputs.
#define DFB_GPU_STAGE_INTERFACE(X)                                                              \
    X(ATTR_POSITION, 0, "vec3 world position of a caster vertex (positionVao)")                 \
    X(OUT_COLOR, 0, "the colour output: draw buffer 0, colour attachment 0 (gl::makeFramebuffer)")

// Limits the shaders size arrays and work groups with.
#define DFB_GPU_LIMITS(X)                                                                          \
    X(BENDY_MAX_SEGMENTS, dfb::lightmath::MAX_SEGMENTS, "a chain's segments (BendyLight.h)")            \
    X(BENDY_MAX_POINTS, dfb::lightmath::MAX_CONTROL_POINTS, "a chain's control points (BendyLight.h)") \
    X(COMPUTE_GROUP_SIZE, 64, "local_size_x of the compute passes (the engine dispatches by it)")  \
    X(FOOTPRINT_MAX_TAPS, 16, "edge taps per sample over its pixel footprint (ViewBlock.footprintTaps)") \
    X(LTC_SIZE, dfb::lightmath::LTC_SIZE, "rows and columns of the LTC tables (Ltc.h)")                    \
    X(LTC_DISK_NEWTON_STEPS, dfb::lightmath::LTC_DISK_NEWTON_STEPS, "Newton steps of the disk's ellipse (Ltc.h)") \
    X(ENV_LEVELS, 6, "mip levels of the prefiltered environment, roughness 0 .. 1 (EnvironmentMap.cpp)") \
    X(ENV_DFG_SIZE, 32, "rows and columns of the DFG table")                                      \
    X(ENV_LOBE_RINGS, dfb::lightmath::ENV_LOBE_RINGS, "rings of a sample's specular lobe, one prefiltered read each (Environment.h)") \
    X(ENV_IRRADIANCE_WIDTH, 32, "texels across the exact irradiance map (16 rows)")                   \
    X(ENV_SUN_SLOTS, 3, "suns an environment light's pass shades (Rig.h ENV_MAX_SUNS; LightShading.cpp asserts it)") \
    X(HORIZON_AZIMUTH_COUNT, dfb::lightmath::HORIZON_AZIMUTHS, "azimuths of a sample's near-field horizon (Horizon.h)") \
    X(AREA_MAX_LAYERS, 256, "an area light's shadow maps: MAX_AREA_SHADOW_GRID squared (Rig.h; ShadowMaps.cpp asserts it)") \
    X(BENDY_DRAW_COMMAND_WORDS, sizeof(dfb::engine::BendyDrawCommands) / 4, "uints in BendyDrawCommands") \
    X(BENDY_TESS_WORK_WORD, offsetof(dfb::engine::BendyDrawCommands, tessWork) / 4, "BendyDrawCommands.tessWork's uint")

// Real-valued limits (GLSL float literals; C++ constexpr float).
#define DFB_GPU_FLOAT_LIMITS(X)                                                                    \
    X(RADIANCE_LIMIT, 1e25f,                                                                       \
      "largest radiance one light contributes to a pixel (colour x intensity applied): far above "  \
      "any physical light (a 1e5 lux sun reflects ~3e4), and 2^20 (the largest exposure) times "    \
      "3e7 such lights stays below float's 3.4e38, so no output overflows to Inf")

namespace dfb::engine {

#define DFB_GPU_FLOAT_LIMIT(name, value, what) constexpr float name = value;
DFB_GPU_FLOAT_LIMITS(DFB_GPU_FLOAT_LIMIT)
#undef DFB_GPU_FLOAT_LIMIT

#define DFB_GPU_ENUMERATOR(name, value, what) name = value,
enum TextureUnit : unsigned { DFB_GPU_TEXTURE_UNITS(DFB_GPU_ENUMERATOR) };
enum StorageBinding : unsigned { DFB_GPU_STORAGE_BINDINGS(DFB_GPU_ENUMERATOR) };
enum UniformBinding : unsigned { DFB_GPU_UNIFORM_BLOCKS(DFB_GPU_ENUMERATOR) };
enum UniformLocation : int { DFB_GPU_UNIFORM_LOCATIONS(DFB_GPU_ENUMERATOR) };
enum StageInterface : unsigned { DFB_GPU_STAGE_INTERFACE(DFB_GPU_ENUMERATOR) };
#undef DFB_GPU_ENUMERATOR

/// glDrawElementsIndirect's command (GL 4.5 section 10.4.1), as std430 uints.
struct DrawElementsIndirectCommand {
    uint32_t count, instanceCount, firstIndex, baseVertex, baseInstance;
};
/// The deformed shadow map's four indirect draws (SSBO_DRAW_COMMANDS; `commands` in
/// bendy_classify.comp, which indexes it as uints: 5 per command, in this order). The classify
/// pass adds to the counts; the engine sets the first indices. tessWork: the sum over the
/// tessellated triangles of their level squared, about the triangles the tessellator will make
/// (BendyShadow::draw bounds it).
struct BendyDrawCommands {
    DrawElementsIndirectCommand plainClosed, plainOpen, tessClosed, tessOpen;
    uint32_t tessWork, pad[3];
};
static_assert(offsetof(BendyDrawCommands, plainOpen) == 5 * 4 && offsetof(BendyDrawCommands, tessClosed) == 10 * 4 &&
              offsetof(BendyDrawCommands, tessOpen) == 15 * 4 && offsetof(BendyDrawCommands, tessWork) == 20 * 4 &&
              sizeof(BendyDrawCommands) == 24 * 4);

enum Limit : unsigned {
#define DFB_GPU_LIMIT(name, value, what) name = unsigned(value),
    DFB_GPU_LIMITS(DFB_GPU_LIMIT)
#undef DFB_GPU_LIMIT
};

/// One sun of an environment light's map (engine extractSuns), a directional light of unit
/// intensity shaded in the environment's own pass (EnvSunBlock, UBO_ENV_SUNS). GLSL mirror: EnvSun
/// in relight_env.frag. The shadow terms are those its LightBlock would carry (LightShading.cpp,
/// lightBlock).
struct EnvSunData {
    glm::mat4 worldToLightClip; // its shadow map's projection
    glm::vec4 toSun;            // xyz unit direction towards it, w = 1 / its shadow map's size
    glm::vec4 weight;           // rgb its irradiance at normal incidence (per unit radiance of the map)
    glm::vec4 shadow;           // x = normal offset, y = lift towards it (world; LightBlock's
                                // lightShadow.w and lightCone.w), z = 1 if it has a shadow map,
                                // w = its filter radius (Light::shadowFilter)
};
static_assert(offsetof(EnvSunData, toSun) == 64);
static_assert(offsetof(EnvSunData, weight) == 80);
static_assert(offsetof(EnvSunData, shadow) == 96);
static_assert(sizeof(EnvSunData) == 112);
struct EnvSunBlock {
    EnvSunData sun[ENV_SUN_SLOTS];
    glm::ivec4 count; // x = the suns in use
};
static_assert(offsetof(EnvSunBlock, count) == ENV_SUN_SLOTS * 112);

/// The light being rendered or shaded (UBO_LIGHT). GLSL mirror: LightBlock in common_uniforms.glsl.
struct LightBlock {
    glm::mat4 worldToLightClip;
    glm::vec4 lightPosition;
    glm::vec4 lightAxis;
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
static_assert(offsetof(LightBlock, lightCone) == 96);
static_assert(offsetof(LightBlock, lightShadow) == 112);
static_assert(offsetof(LightBlock, lightRight) == 128);
static_assert(offsetof(LightBlock, lightUp) == 144);
static_assert(offsetof(LightBlock, lightDoors) == 160);
static_assert(offsetof(LightBlock, lightCube) == 176);
static_assert(sizeof(LightBlock) == 192);

/// The shot's view (UBO_VIEW). GLSL mirror: ViewBlock in common_uniforms.glsl.
struct ViewBlock {
    glm::vec4 cameraPosition; // w = 1 if orthographic
    glm::vec4 cameraForward;
    glm::vec4 exposure;
    glm::ivec4 sampleLayout;  // x = width of the sample textures, y = log2 of it (deep buffers: a power of two),
                              // z = edge taps per sample (1..FOOTPRINT_MAX_TAPS; 1 = none)
    glm::vec4 cameraRight;    // xyz unit image right; w = a pixel's width at unit depth (perspective) or in scene units
    glm::vec4 cameraDown;     // xyz unit direction of increasing rows (the camera's -up)
    // The edge taps' offsets from the pixel centre in pixels (the bake's sample pattern), two per
    // element: tap 2i in xy, tap 2i + 1 in zw.
    glm::vec4 footprintTaps[FOOTPRINT_MAX_TAPS / 2];
};
static_assert(offsetof(ViewBlock, cameraForward) == 16);
static_assert(offsetof(ViewBlock, exposure) == 32);
static_assert(offsetof(ViewBlock, sampleLayout) == 48);
static_assert(offsetof(ViewBlock, cameraRight) == 64);
static_assert(offsetof(ViewBlock, cameraDown) == 80);
static_assert(offsetof(ViewBlock, footprintTaps) == 96);
static_assert(sizeof(ViewBlock) == 96 + FOOTPRINT_MAX_TAPS * 8);
static_assert(FOOTPRINT_MAX_TAPS % 2 == 0, "two taps per vec4");

/// A BendyLight's chain. GLSL mirror: BendyBlock in server/shaders/common_bendy.glsl (whose arrays
/// are sized by BENDY_MAX_POINTS and BENDY_MAX_SEGMENTS, generated from the same constants).
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
    // x radius at p2 - radius at p0, y slope term m; z the segment's largest curvature (1/length)
    // over t in [0, 1], for the deformed map's edge levels (bendyEdgeLevel in common_bendy.glsl)
    glm::vec4 coneRadius[lightmath::MAX_SEGMENTS];
};
// std140: vec4 arrays are tightly packed, 16 bytes an element.
constexpr size_t POINTS_BYTES = lightmath::MAX_CONTROL_POINTS * 16, SEGMENTS_BYTES = lightmath::MAX_SEGMENTS * 16;
static_assert(offsetof(BendyBlock, c) == POINTS_BYTES);
static_assert(offsetof(BendyBlock, frameV) == 2 * POINTS_BYTES);
static_assert(offsetof(BendyBlock, axisU) == 2 * POINTS_BYTES + SEGMENTS_BYTES + 16);
static_assert(offsetof(BendyBlock, end) == 2 * POINTS_BYTES + SEGMENTS_BYTES + 4 * 16);
static_assert(offsetof(BendyBlock, coneStart) == 2 * POINTS_BYTES + SEGMENTS_BYTES + 5 * 16);
static_assert(offsetof(BendyBlock, coneRadius) == 2 * POINTS_BYTES + 3 * SEGMENTS_BYTES + 5 * 16);
static_assert(sizeof(BendyBlock) == 2 * POINTS_BYTES + 4 * SEGMENTS_BYTES + 5 * 16);

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
        // Curvature of the quadratic B(t) = p0 (1-t)^2 + 2 p1 t (1-t) + p2 t^2 (eq. 1): with
        // a = p1 - p0, e = p2 - p1, B' = 2 (a + (e - a) t) and B'' = 2 (e - a), so
        // |B' x B''| = 4 |a x e| and kappa(t) = |a x e| / (2 |a + (e - a) t|^3), largest where
        // |B'| is least: t* = -a.(e - a) / |e - a|^2 clamped to [0, 1].
        const glm::vec3 a = p1 - p0, e = p2 - p1, da = e - a;
        const float dd = glm::dot(da, da);
        const float ts = dd > 0.f ? std::clamp(-glm::dot(a, da) / dd, 0.f, 1.f) : 0.f;
        const float speed = glm::length(a + da * ts);
        const float kappaMax = speed > 0.f ? glm::length(glm::cross(a, e)) / (2.f * speed * speed * speed) : 0.f;
        b.coneRadius[k] = glm::vec4(dr, m, kappaMax, 0.f);
    }
    return b;
}

} // namespace dfb::engine
