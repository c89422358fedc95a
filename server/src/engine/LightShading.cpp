#include "LightShading.h"

#include "GpuInterface.h"

#include "ShadowMaps.h"

#include <dfb/lightmath/Environment.h>
#include <dfb/lightmath/LtcTableData.h>
#include <dfb/server/AreaPattern.h>
#include <dfb/server/BentArea.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace dfb::engine {

static_assert(ENV_SUN_SLOTS == ENV_MAX_SUNS, "relight_env.frag shades every sun the engine takes out of a map");

namespace {
// A float as a GLSL literal (scientific notation: always a float, never an int).
std::string glslFloat(float v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.9e", double(v));
    return buf;
}
} // namespace
namespace {

// The longest one band of an area light's reference may take (the engine's GPU watchdog's).
constexpr GLuint64 REFERENCE_BAND_TIMEOUT_NS = 20'000'000'000ull;

// The light as the relight shaders see it (common_uniforms.glsl's LightBlock).
LightBlock lightBlock(const LightCache& c, bool cookie, const glm::vec3& patternMean) {
    const Light& l = c.params;
    LightBlock block{};
    block.worldToLightClip = c.worldToLightClip;
    // w = 0 marks a directional light: parallel rays, no distance or cone falloff.
    block.lightPosition = glm::vec4(toGlm(l.position), l.type == LightType::Directional   ? 0.f
                                                       : l.type == LightType::Point       ? 2.f
                                                       : l.type == LightType::Area        ? 3.f
                                                       : l.type == LightType::Environment ? 4.f
                                                                                          : 1.f);
    if (l.type == LightType::Environment) {
        // relight_env.frag: the world-to-map rotation (R^T of envRotation) and the shadow flag.
        block.worldToLightClip = glm::mat4(glm::transpose(glm::mat3(lightmath::envRotation(l.envRotationDeg))));
        block.lightCone = glm::vec4(0.f, 0.f, l.shadow ? 1.f : 0.f, 0.f);
        return block;
    }
    const glm::vec3 axis = glm::normalize(toGlm(l.direction));
    block.lightAxis = glm::vec4(axis, 0.f);
    const float outer = glm::radians(l.coneAngleDeg);
    const float inner = glm::radians(std::max(l.coneAngleDeg - l.penumbraDeg, 0.f));
    // The world size of a shadow-map texel per unit distance (perspective maps), or its one size.
    const int mapSize = c.hasShadow ? c.shadowSize : l.shadowMapSize;
    float texel = texelPerDistance(l, mapSize);
    if (l.type == LightType::Area) texel = 2.f * std::tan(c.areaHalfAngle) / float(std::max(mapSize, 1));
    if (l.type == LightType::Directional) {
        // Orthographic texels have one world size: the frustum's width over the map's.
        const glm::mat4 m = glm::inverse(c.worldToLightClip);
        const float width = glm::length(glm::vec3(m * glm::vec4(1, 0, 0, 1)) / (m * glm::vec4(1, 0, 0, 1)).w -
                                        glm::vec3(m * glm::vec4(-1, 0, 0, 1)) / (m * glm::vec4(-1, 0, 0, 1)).w);
        texel = width / float(std::max(mapSize, 1));
    }
    // Receiver-plane depth bias (common_uniforms.glsl, filteredShadowPlane; docs/lighting.md,
    // Shadows): every texel the filter reads is compared with the receiver plane's own depth at
    // that texel, so a planar receiver needs no offset at any angle, and what is left is small:
    //  - the receiver is lifted towards the light by RECEIVER_LIFT_TEXELS along the light ray (a
    //    depth-only bias: the lookup does not move): the rounding between llvmpipe's rasterised
    //    depth of large triangles and the shaders' projection of the same point, and a
    //    BendyLight's casters subdivided only to within a quarter texel of the deformed surface;
    //  - and moved along its geometric normal by shadowBias texels (default 0.15) at every angle:
    //    a curved mesh's neighbouring facets inside the filter's reach lie off the receiver's
    //    plane by their curvature (the Stanford dragon under a sun: 4 % too much shadow without).
    // Both were chosen by measurement (tests/gpu/engine_shadow_bias_test.cpp, the table in
    // docs/lighting.md); a larger offset pushes shadows off their contacts (issue 16).
    constexpr float RECEIVER_LIFT_TEXELS = 1.f;
    block.lightCone = glm::vec4(std::cos(outer), std::max(std::cos(inner), std::cos(outer) + 1e-5f),
                                l.shadow ? 1.f : 0.f, RECEIVER_LIFT_TEXELS * texel);
    block.lightShadow = glm::vec4(1.f / float(std::max(mapSize, 1)), float(l.shadowFilter),
                                  c.shadowIsCube() ? 1.f : 0.f, l.shadowBias * texel);
    // The spot's frame, as its shadow frustum's (lightViewProj): barn doors and cookie.
    const glm::vec3 right = glm::normalize(glm::cross(axis, frustumUp(axis)));
    block.lightRight = glm::vec4(right, cookie ? 1.f : 0.f);
    block.lightUp = glm::vec4(glm::cross(right, axis), std::tan(outer));
    // An open door (90 degrees) must never cut: put it out of atan's reach.
    auto door = [&](int i) { return l.barnDoorsDeg[size_t(i)] >= 90.f ? 10.f : glm::radians(l.barnDoorsDeg[size_t(i)]); };
    block.lightDoors = l.type == LightType::Spot ? glm::vec4(door(0), door(1), door(2), door(3)) : glm::vec4(10.f);
    // z: a bent area light's interior light, a Lambertian emitter's cell (BENDY_EMITTER_COSINE).
    block.lightCube = glm::vec4(c.cubeNearFar, c.emitterCosine ? 1.f : 0.f, 0.f);
    if (l.type == LightType::Area) {
        // common_area.glsl's layout of the block.
        const auto f = areaFrameOf<float>(l);
        block.lightAxis = glm::vec4(f.normal, 0.f);
        block.lightRight = glm::vec4(f.right, f.width);
        block.lightUp = glm::vec4(f.up, f.height);
        block.lightDoors = glm::vec4(l.alphaBeta[0], l.alphaBeta[1], f.disk ? 1.f : 0.f, float(std::max(c.shadowLayers, 1)));
        block.lightCube = glm::vec4(patternMean, 0.f);
    }
    return block;
}

void setRelightUniforms(int output, bool linked, int step) {
    glUniform1i(LOC_RELIGHT_OUTPUT, output);
    glUniform1i(LOC_RELIGHT_LINKED, linked ? 1 : 0);
    glUniform1i(LOC_RELIGHT_PIXEL_STEP, step);
}

} // namespace

Status LightShading::init() {
    auto resolve = mShaders.variant({"common_fullscreen.vert", "composite_resolve.frag"});
    if (!resolve) return resolve.error();
    mResolveProgram = resolve.value();
    GLuint vao = 0;
    glCreateVertexArrays(1, &vao);
    mEmptyVao = gl::VertexArray(vao);
    // The LTC tables (dfb-ltc-fit, generated at build time; Ltc.h's layout: texel (i, j) =
    // (roughness, sqrt(1 - N.v)) at k = j LTC_SIZE + i, which is GL's row-major upload). Read by
    // texelFetch and interpolated by hand in common_ltc.glsl: 64 KiB + 32 KiB, made once.
    static_assert(sizeof(lightmath::LTC_MATRIX) == size_t(LTC_SIZE) * LTC_SIZE * 4 * sizeof(float));
    static_assert(sizeof(lightmath::LTC_AMPLITUDE) == size_t(LTC_SIZE) * LTC_SIZE * 2 * sizeof(float));
    mLtcMatrix = gl::makeTexture2D(GL_RGBA32F, LTC_SIZE, LTC_SIZE);
    glTextureSubImage2D(mLtcMatrix.id(), 0, 0, 0, LTC_SIZE, LTC_SIZE, GL_RGBA, GL_FLOAT, lightmath::LTC_MATRIX);
    mLtcAmplitude = gl::makeTexture2D(GL_RG32F, LTC_SIZE, LTC_SIZE);
    glTextureSubImage2D(mLtcAmplitude.id(), 0, 0, 0, LTC_SIZE, LTC_SIZE, GL_RG, GL_FLOAT, lightmath::LTC_AMPLITUDE);
    // The split sum's DFG table (Environment.h dfgTable), generated here rather than copied:
    // 32 x 32 entries of 512 GGX samples, a few milliseconds once per engine. Read bilinearly
    // at (N.v, roughness), the entries at texel centres.
    const std::vector<float> dfg = lightmath::dfgTable(ENV_DFG_SIZE, 512);
    mEnvDfg = gl::makeTexture2D(GL_RG32F, ENV_DFG_SIZE, ENV_DFG_SIZE);
    glTextureSubImage2D(mEnvDfg.id(), 0, 0, 0, ENV_DFG_SIZE, ENV_DFG_SIZE, GL_RG, GL_FLOAT, dfg.data());
    glTextureParameteri(mEnvDfg.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(mEnvDfg.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(mEnvDfg.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(mEnvDfg.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    return okStatus();
}

// The relight shaders' specialisation for this light (see common_uniforms.glsl): every define
// fixes a path the light takes or cannot take, so each variant computes what the generic shader
// would, without the others' cost.
std::string LightShading::shadeDefines(const LightCache& c, int output, bool cookie, bool linked) const {
    if (mShaders.generic()) return "";
    const Light& l = c.params;
    std::string d;
    auto def = [&d](const char* name, const std::string& value) { d += std::string("#define ") + name + " " + value + "\n"; };
    auto flag = [&def](const char* name, bool on) { def(name, on ? "true" : "false"); };
    def("SHADE_KIND", l.type == LightType::Directional   ? "0"
                      : l.type == LightType::Point       ? "2"
                      : l.type == LightType::Area        ? "3"
                      : l.type == LightType::Environment ? "4"
                                                         : "1");
    flag("SHADE_SHADOWED", l.shadow);
    def("SHADE_PCF_RADIUS", std::to_string(l.shadowFilter));
    flag("SHADE_COOKIE", cookie);
    bool doors = false;
    for (float a : l.barnDoorsDeg) doors = doors || a < 90.f;
    flag("SHADE_DOORS", l.type == LightType::Spot && doors);
    flag("SHADE_LINKED", linked);
    def("SHADE_OUTPUT", std::to_string(output));
    flag("SHADE_SHEEN", mGBuffer.hasSheen);
    flag("SHADE_COAT", mGBuffer.hasCoat);
    if (l.type == LightType::Area) def("AREA_LAYERS", std::to_string(std::max(c.shadowLayers, 1)));
    if (l.type == LightType::Bendy) {
        def("BENDY_K", std::to_string(c.bendySegments()));
        flag("BENDY_EXACT", l.exactDirection);
        flag("BENDY_EMITTER_COSINE", c.emitterCosine);
    }
    return d;
}

// A deep buffer's full frames shade once per sample over the sample textures' layout (the flat
// shaders, DFB_FLAT_SAMPLES, read the sample at their fragment) and then sum each pixel's
// samples: no per-pixel loop whose longest pixel every lane of a group waits for.
Result<GLuint> LightShading::target(LightCache& c, bool perSample) {
    if (!c.contribution) {
        // Full float: a contribution is shaded at unit radiance and scaled by colour x intensity
        // in the composite (up to 1e18), so its own values span what the G-buffer's geometry
        // gives (1/d^2, a GGX peak) and half float's 11-bit mantissa and 65504 ceiling would show.
        c.contribution = gl::makeTexture2D(GL_RGBA32F, mGBuffer.width, mGBuffer.height);
        if (!mMaskDepth) mMaskDepth = gl::makeTexture2D(GL_DEPTH_COMPONENT32F, mGBuffer.width, mGBuffer.height);
        auto fb = gl::makeFramebuffer(c.contribution.id(), mMaskDepth.id(), "contribution of light '" + c.params.name + "'");
        if (!fb) return fb.error();
        c.contributionFb = std::move(fb.value());
    }
    if (!perSample) return c.contributionFb.id();
    if (!mSampleFb) {
        mSampleRadiance = gl::makeTexture2D(GL_RGBA32F, mGBuffer.sampleRow, mGBuffer.sampleRows);
        mSampleDepth = gl::makeTexture2D(GL_DEPTH_COMPONENT32F, mGBuffer.sampleRow, mGBuffer.sampleRows);
        auto fb = gl::makeFramebuffer(mSampleRadiance.id(), mSampleDepth.id(), "per-sample radiance");
        if (!fb) return fb.error();
        mSampleFb = std::move(fb.value());
    }
    return mSampleFb.id();
}

// A light reaches part of the frame (the surfaces facing it; a spot's cone; a BendyLight's tubes):
// mark that footprint in the depth buffer first, and the shading pass's early depth test skips
// the rest (relight_mask.frag). Leaves the depth test on, equal, without writes.
Status LightShading::markFootprint(GLuint target, const std::string& defines, bool bendy, int step, bool clearColor, int coverage) {
    const float zero[4] = {0.f, 0.f, 0.f, 0.f}, far = 1.f;
    if (clearColor) glClearNamedFramebufferfv(target, GL_COLOR, 0, zero);
    // The depth texture the target's footprint goes to (LightShading::target).
    const bool samples = target == mSampleFb.id();
    const GLuint depth = samples ? mSampleDepth.id() : mMaskDepth.id();
    const int w = samples ? mGBuffer.sampleRow : mGBuffer.width, h = samples ? mGBuffer.sampleRows : mGBuffer.height;
    if (coverage >= 0 && mCoverage[coverage]) {
        // A copy instead of the mask pass (a full-screen pass reading every sample's position).
        glCopyImageSubData(mCoverage[coverage].id(), GL_TEXTURE_2D, 0, 0, 0, 0, depth, GL_TEXTURE_2D, 0, 0, 0, 0, w, h, 1);
        glEnable(GL_DEPTH_TEST);
        glDepthFunc(GL_EQUAL);
        glDepthMask(GL_FALSE);
        return okStatus();
    }
    auto mask = mShaders.variant({"common_fullscreen.vert", "relight_mask.frag"}, defines + (bendy ? "#define SHADE_BENDY 1\n" : ""));
    if (!mask) return mask.error();
    glClearNamedFramebufferfv(target, GL_DEPTH, 0, &far);
    glUseProgram(mask.value());
    glUniform1i(LOC_RELIGHT_PIXEL_STEP, step);
    glBindTextureUnit(TEX_GBUFFER_P, mGBuffer.P.id());
    glBindTextureUnit(TEX_GBUFFER_N, mGBuffer.N.id());
    glBindTextureUnit(TEX_GBUFFER_NG, mGBuffer.Ng.id()); // the pixel footprint (edge taps)
    glBindTextureUnit(TEX_PIXEL_SAMPLES, mGBuffer.pixelSamples.id());
    glBindVertexArray(mEmptyVao.id());
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_ALWAYS);
    glDepthMask(GL_TRUE);
    glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glDepthFunc(GL_EQUAL);
    glDepthMask(GL_FALSE);
    if (coverage >= 0) {
        mCoverage[coverage] = gl::makeTexture2D(GL_DEPTH_COMPONENT32F, w, h);
        glCopyImageSubData(depth, GL_TEXTURE_2D, 0, 0, 0, 0, mCoverage[coverage].id(), GL_TEXTURE_2D, 0, 0, 0, 0, w, h, 1);
    }
    return okStatus();
}

// Light linking: a bit per object id, lit where set.
void LightShading::bindLinkMask(LightCache& c, bool linked) {
    const Light& l = c.params;
    if (linked) {
        std::vector<uint32_t> mask((std::max(mGBuffer.maxObjectId, 1u) + 32) / 32, l.include.empty() ? ~0u : 0u);
        auto setBit = [&](uint32_t id, bool on) {
            if (id / 32 >= mask.size()) return;
            if (on) mask[id / 32] |= 1u << (id % 32);
            else mask[id / 32] &= ~(1u << (id % 32));
        };
        for (uint32_t id : l.include) setBit(id, true);
        for (uint32_t id : l.exclude) setBit(id, false);
        c.linkMask = gl::makeBuffer(mask.data(), mask.size() * sizeof(uint32_t));
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, SSBO_LINK_MASK, c.linkMask.id());
        return;
    }
    if (!mNoLink) {
        const uint32_t all = ~0u;
        mNoLink = gl::makeBuffer(&all, sizeof all);
    }
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, SSBO_LINK_MASK, mNoLink.id());
}

Status LightShading::shade(LightCache& c, int output, bool preview, int referenceCells) {
    if (c.params.type == LightType::BentArea) return shadeBentArea(c, output, preview);
    return shadeInto(c, c, output, preview, referenceCells, {});
}

// A bent area light (paper 003 section 4.1): the sum of its interior BendyLights, each shaded as a
// BendyLight whose intensity is its cell's share of the emitter (bentAreaCellArea, candela per
// unit radiance) with a Lambertian emitter's cosine, into this light's contribution. The interior
// lights are those its shadow maps were rendered for (or, unshadowed, the grid it has now).
Status LightShading::shadeBentArea(LightCache& c, int output, bool preview) {
    const Light& l = c.params;
    syncInterior(c, l.shadow && c.hasShadow ? c.interiorGrid : areaGridFor(l, preview));
    const float cells = float(std::max<size_t>(c.interior.size(), 1));
    // Radiance: each interior light's candela per unit radiance; a shadow mask: the mean.
    const float weight = output == 0 ? bentAreaCellArea(l, c.interiorGrid) : 1.f / cells;
    if (c.interior.empty()) {
        auto target = this->target(c, false);
        if (!target) return target.error();
        const float zero[4] = {0.f, 0.f, 0.f, 0.f};
        glClearNamedFramebufferfv(target.value(), GL_COLOR, 0, zero);
    }
    for (size_t k = 0; k < c.interior.size(); ++k) {
        if (auto s = shadeInto(c.interior[k], c, output, preview, 0, {true, k == 0, glm::vec3(weight)}); !s) return s;
    }
    c.hasContribution = true;
    if (output == 0) {
        c.previewShading = preview;
        c.scale = radiance(l);
        ++c.version;
    }
    return okStatus();
}

Status LightShading::shadeInto(LightCache& c, LightCache& into, int output, bool preview, int referenceCells, Accumulation acc) {
    const Light& l = c.params;
    const bool bendy = l.type == LightType::Bendy, area = l.type == LightType::Area;
    GLuint cookie = 0;
    if (l.type == LightType::Spot && !l.cookie.empty()) {
        auto t = mCookies.texture(l);
        if (!t) return t.error();
        cookie = t.value();
    }
    glBindTextureUnit(TEX_COOKIE, cookie);
    Cookies::Pattern pattern;
    if (area) {
        auto p = mCookies.pattern(l);
        if (!p) return p.error();
        pattern = p.value();
        glBindTextureUnit(TEX_AREA_PATTERN, pattern.texture);
        glBindTextureUnit(TEX_LTC_MATRIX, mLtcMatrix.id());
        glBindTextureUnit(TEX_LTC_AMPLITUDE, mLtcAmplitude.id());
        if (!c.areaLayers) {
            const std::vector<glm::vec4> none(size_t(AREA_MAX_LAYERS), glm::vec4(0.f));
            c.areaLayers = gl::makeBuffer(none.data(), none.size() * sizeof(glm::vec4));
        }
        glBindBufferBase(GL_UNIFORM_BUFFER, UBO_AREA_LAYERS, c.areaLayers.id());
    }
    const bool environment = l.type == LightType::Environment;
    int sunCount = 0, sunFilter = 0; // its suns, and their filter radius (environmentSun's shadowFilter)
    if (environment) {
        // The map's spherical harmonics, turned by the light's rotation: the map's own, projected
        // once, turned band by band (shRotate25: 0.04 ms, where projecting the turned map's small
        // copy took 2.5 ms of every rotation's frame before its GPU work could start).
        auto env = mCookies.environment(l);
        if (!env) return env.error();
        const auto L = lightmath::shRotate25(env->coefficients, lightmath::envRotation(l.envRotationDeg));
        glm::vec4 sh[lightmath::SH_TRANSFER_COEFFICIENTS];
        for (int i = 0; i < lightmath::SH_TRANSFER_COEFFICIENTS; ++i) sh[i] = glm::vec4(glm::vec3(L[size_t(i)]), 0.f);
        c.envSh = gl::makeBuffer(sh, sizeof sh);
        // A uniform block, not a storage buffer: every sample reads the same 25 values, which
        // llvmpipe then loads once per pass instead of per lane (the rotation's environment pass
        // at 960x540 read them 50 times per sample).
        glBindBufferBase(GL_UNIFORM_BUFFER, UBO_ENV_SH, c.envSh.id());
        // What the expansion misses, in the map's frame (Cookies::irradianceResidual).
        glBindTextureUnit(TEX_ENV_IRRADIANCE, env->irradianceResidual);
        glBindTextureUnit(TEX_ENV_PREFILTERED, env->texture);
        glBindTextureUnit(TEX_ENV_DFG, mEnvDfg.id());
        // The map's suns (GlEngine::updateShadows keeps c.interior one per env->suns): directional
        // lights of unit intensity, each weighted by its irradiance so that the sum is at the
        // environment's unit radiance, shaded in this pass (relight_env.frag sunsRadiance): one
        // read of the sample and one footprint for all (rotation at 960x540 on llvmpipe: a
        // footprint and a shading pass fewer per sun).
        EnvSunBlock suns{};
        const size_t count = output == 0 ? std::min(env->suns.size(), c.interior.size()) : 0;
        suns.count = glm::ivec4(int(count), 0, 0, 0);
        for (size_t k = 0; k < size_t(ENV_SUN_SLOTS); ++k) {
            const bool used = k < count;
            if (used) {
                const LightCache& sun = c.interior[k];
                const LightBlock b = lightBlock(sun, false, glm::vec3(0.f));
                suns.sun[k].worldToLightClip = b.worldToLightClip;
                suns.sun[k].toSun = glm::vec4(-glm::vec3(b.lightAxis), b.lightShadow.x);
                suns.sun[k].weight = glm::vec4(env->suns[k].irradiance, 0.f);
                suns.sun[k].shadow =
                    glm::vec4(b.lightShadow.w, b.lightCone.w, sun.hasShadow ? 1.f : 0.f, float(sun.params.shadowFilter));
            }
            const bool map = used && c.interior[k].hasShadow && c.interior[k].shadowTarget == GL_TEXTURE_2D;
            glBindTextureUnit(TEX_ENV_SUN_MAPS + unsigned(k), map ? c.interior[k].shadowMap.id() : 0);
        }
        c.envSuns = gl::makeBuffer(&suns, sizeof suns);
        glBindBufferBase(GL_UNIFORM_BUFFER, UBO_ENV_SUNS, c.envSuns.id());
        sunCount = int(count);
        if (count > 0) sunFilter = c.interior[0].params.shadowFilter;
    }
    mLight.upload(lightBlock(c, cookie != 0, pattern.mean));

    // Preview frames shade every second pixel into a half-size image (progressive refinement);
    // shadow masks and full frames shade every pixel.
    const int step = preview && output == 0 ? 2 : 1;
    const bool perSample = !mGBuffer.flat && !mShaders.generic() && step == 1;
    auto target = this->target(into, perSample);
    if (!target) return target.error();
    glBindFramebuffer(GL_FRAMEBUFFER, target.value());
    if (perSample) glViewport(0, 0, mGBuffer.sampleRow, mGBuffer.sampleRows);
    else glViewport(0, 0, (mGBuffer.width + step - 1) / step, (mGBuffer.height + step - 1) / step);
    glDisable(GL_BLEND);
    glDisable(GL_DEPTH_TEST);
    const bool linked = !l.include.empty() || !l.exclude.empty();
    if (bendy) uploadBendy(c);
    // Edge taps over each sample's pixel footprint: the shot's, one in preview frames (drags stay
    // as cheap as before; the refined frame has them).
    const int taps = step == 1 ? mGBuffer.footprintTaps : 1;
    const std::string defines =
        shadeDefines(c, output, cookie != 0, linked) +
        (mShaders.generic() ? "" : "#define SHADE_FOOTPRINT_TAPS " + std::to_string(taps) + "\n") +
        (perSample ? "#define DFB_FLAT_SAMPLES 1\n" : "") +
        (area && referenceCells > 0 ? "#define AREA_REFERENCE " + std::to_string(referenceCells) + "\n" : "") +
        // Whether the shot holds the environment transfer is not a specialisation either.
        (environment && mGBuffer.hasEnvTransfer
             ? "#define ENV_TRANSFER 1\n#define ENV_BANDS " + std::to_string(mGBuffer.envBands) + "\n#define ENV_LAYERS " +
                   std::to_string(mGBuffer.envLayers) + "\n"
             : "") +
        (environment && mGBuffer.hasEnvLobe ? "#define ENV_LOBE 1\n" : "") +
        (environment && mGBuffer.hasEnvRings ? "#define ENV_RINGS 1\n" : "") +
        (environment && !mShaders.generic()
             ? "#define ENV_SUNS " + std::to_string(sunCount) + "\n#define ENV_SUN_FILTER " + std::to_string(sunFilter) + "\n"
             : "") +
        // Nor whether it holds the near-field horizon, which straight and bent lights' shadows
        // (and an environment's suns') read.
        (mGBuffer.hasHorizon && !area
             ? "#define NEAR_FIELD_HORIZON 1\n#define NEAR_FIELD_REACH " + glslFloat(mGBuffer.horizonRadius) + "\n"
             : "") +
        // Which shading the light asks for is not a specialisation: generic shaders need it too.
        // 1: a rectangle, 2: a disk (common_ltc.glsl runs only that one's integral).
        (area && referenceCells == 0 && shadesWithLtc(l)
             ? std::string("#define AREA_LTC ") + (l.areaShape == AreaShape::Disk ? "2" : "1") + "\n"
             : std::string());
    auto shader = mShaders.variant({"common_fullscreen.vert", bendy         ? "relight_bendy.frag"
                                                              : area        ? "relight_area.frag"
                                                              : environment ? "relight_env.frag"
                                                                            : "relight_spot.frag"},
                                   defines);
    if (!shader) return shader.error();
    const bool footprint = !mShaders.generic();
    // An environment light reaches every covered sample (relight_mask.frag): that footprint is the
    // shot's, kept once per target layout. Its contribution's pixels outside it are never written,
    // so they are still zero when it was last shaded over the same footprint: no clear (8 MB of
    // RGBA32F at 960x540).
    const int coverage = footprint && environment ? (perSample ? 2 : step == 1 ? 0 : 1) : -1;
    if (footprint) {
        const bool zeroOutside = !perSample && coverage >= 0 && into.coverageWritten == coverage;
        const bool clear = (perSample || !acc.on || acc.first) && !zeroOutside;
        if (auto s = markFootprint(target.value(), defines, bendy, step, clear, coverage); !s) return s;
    }
    // Accumulating: the pass adds weight x its radiance (or replaces with it, the first), straight
    // into the target or through the per-sample resolve.
    auto blend = [&acc] {
        if (!acc.on) return;
        glEnable(GL_BLEND);
        glBlendColor(acc.weight.r, acc.weight.g, acc.weight.b, 1.f);
        glBlendFunc(GL_CONSTANT_COLOR, acc.first ? GL_ZERO : GL_ONE);
    };
    if (!perSample) blend();
    glUseProgram(shader.value());
    setRelightUniforms(output, linked, step);
    bindLinkMask(c, linked);
    mGBuffer.bindForShading();
    // An unshadowed light still needs a complete texture on the shadow unit: reuse its own or any.
    glBindTextureUnit(TEX_SHADOW_MAP, c.shadowMap && c.shadowTarget == GL_TEXTURE_2D ? c.shadowMap.id() : 0);
    glBindTextureUnit(TEX_SHADOW_CUBE, c.shadowMap && c.shadowIsCube() ? c.shadowMap.id() : 0);
    glBindTextureUnit(TEX_SHADOW_ARRAY, c.shadowMap && area ? c.shadowMap.id() : 0);
    glBindVertexArray(mEmptyVao.id());
    if (footprint && bendy) {
        // Pixels whose samples lie in at most one segment's round cone (depth 0.25, relight_mask.frag)
        // with the variant that solves one segment; the others (0.75) solve every segment.
        auto single = mShaders.variant({"common_fullscreen.vert", "relight_bendy.frag"}, defines + "#define BENDY_SINGLE 1\n");
        if (!single) return single.error();
        glDepthRange(0.75, 0.75);
        glDrawArrays(GL_TRIANGLES, 0, 3);
        glUseProgram(single.value());
        setRelightUniforms(output, linked, step);
        glDepthRange(0.25, 0.25);
        glDrawArrays(GL_TRIANGLES, 0, 3);
        glDepthRange(0.0, 1.0);
    } else if (referenceCells > 0) {
        // The stratified reference is hundreds of lookups per pixel (seconds a frame on llvmpipe):
        // drawn in bands, each waited for, so that no single submission runs into the engine's
        // GPU watchdog (waitForGpu: 20 s means a hung GPU) on a slow or loaded machine.
        GLint vp[4];
        glGetIntegerv(GL_VIEWPORT, vp);
        constexpr int BANDS = 32;
        glEnable(GL_SCISSOR_TEST);
        for (int b = 0; b < BANDS; ++b) {
            const int y0 = vp[1] + vp[3] * b / BANDS, y1 = vp[1] + vp[3] * (b + 1) / BANDS;
            if (y1 <= y0) continue;
            glScissor(vp[0], y0, vp[2], y1 - y0);
            glDrawArrays(GL_TRIANGLES, 0, 3);
            GLsync band = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
            const GLenum r = band ? glClientWaitSync(band, GL_SYNC_FLUSH_COMMANDS_BIT, REFERENCE_BAND_TIMEOUT_NS) : GLenum(GL_WAIT_FAILED);
            if (band) glDeleteSync(band);
            if (r == GL_TIMEOUT_EXPIRED || r == GL_WAIT_FAILED) {
                glDisable(GL_SCISSOR_TEST);
                return makeError(ErrorCode::GpuError, "light '" + l.name + "': a band of the area light reference took over 20 s");
            }
        }
        glDisable(GL_SCISSOR_TEST);
    } else {
        glDrawArrays(GL_TRIANGLES, 0, 3);
    }
    glDisable(GL_DEPTH_TEST);
    glDepthMask(GL_TRUE);
    glDepthFunc(GL_LESS);
    if (perSample) {
        glBindFramebuffer(GL_FRAMEBUFFER, into.contributionFb.id());
        glViewport(0, 0, mGBuffer.width, mGBuffer.height);
        glUseProgram(mResolveProgram);
        glBindTextureUnit(TEX_INPUT, mSampleRadiance.id());
        glBindTextureUnit(TEX_PIXEL_SAMPLES, mGBuffer.pixelSamples.id());
        blend();
        glDrawArrays(GL_TRIANGLES, 0, 3);
    }
    glDisable(GL_BLEND);
    into.coverageWritten = perSample ? -1 : coverage;
    if (acc.on) return okStatus(); // the bent area light records its own contribution
    c.hasContribution = true;
    if (output == 0 && referenceCells == 0) {
        c.previewShading = step != 1;
        c.scale = radiance(l);
        ++c.version;
    }
    return okStatus();
}

} // namespace dfb::engine
