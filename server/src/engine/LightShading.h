#pragma once
// One light's contribution image from the G-buffer (relight_spot.frag, relight_bendy.frag): its
// footprint first (relight_mask.frag), then the shading pass specialised for the light
// (ShaderVariants), per sample for deep buffers and summed per pixel (composite_resolve.frag).

#include "Cookies.h"
#include "GBufferTextures.h"
#include "LightCache.h"
#include "ShaderVariants.h"
#include "UniformBuffer.h"

#include <dfb/core/Result.h>
#include <dfb/gl/Objects.h>

#include <string>

namespace dfb::engine {

class LightShading {
public:
    LightShading(ShaderVariants& shaders, const GBufferTextures& gbuffer, LightUniforms& light, Cookies& cookies)
        : mShaders(shaders), mGBuffer(gbuffer), mLight(light), mCookies(cookies) {}

    /// Programs and the empty vertex array of the full-screen passes. GL thread.
    Status init();

    /// Shades c.params into c.contribution (allocated on first use), with its shadow map as it is
    /// in c. `output` 0: the light's radiance, recorded as the cached contribution (its radiance,
    /// scale 1, a new version); 1: its shadow mask (the caller marks the contribution stale).
    /// `preview`: radiance at half resolution (every second pixel; c.previewShading).
    /// `referenceCells` > 0 (area lights, output 0): the stratified reference with that many cells
    /// per side instead of one-shot (relight_area.frag AREA_REFERENCE), not recorded as the cached
    /// contribution (the caller marks it stale).
    Status shade(LightCache& c, int output, bool preview, int referenceCells = 0);

private:
    /// How one light's pass writes its target: replacing it (a light of its own), or, for a bent
    /// area light's interior lights, adding `weight` times it (`first`: replacing, weighted).
    struct Accumulation {
        bool on = false;
        bool first = false;
        glm::vec3 weight{1.f}; // per channel
    };
    Status shadeInto(LightCache& c, LightCache& into, int output, bool preview, int referenceCells, Accumulation acc);
    Status shadeBentArea(LightCache& c, int output, bool preview);
    std::string shadeDefines(const LightCache& c, int output, bool cookie, bool linked) const;
    Result<GLuint> target(LightCache& c, bool perSample);
    /// `coverage` >= 0: the footprint is every covered sample (an environment light's), the same
    /// for every frame: kept in mCoverage[coverage] the first time and copied from there after.
    Status markFootprint(GLuint target, const std::string& defines, bool bendy, int step, bool clearColor, int coverage = -1);
    void bindLinkMask(LightCache& c, bool linked);

    ShaderVariants& mShaders;
    const GBufferTextures& mGBuffer;
    LightUniforms& mLight;
    Cookies& mCookies;
    GLuint mResolveProgram = 0; // owned by mShaders
    gl::VertexArray mEmptyVao;
    gl::Texture mLtcMatrix, mLtcAmplitude; // the LTC tables (TEX_LTC_MATRIX, TEX_LTC_AMPLITUDE; Ltc.h)
    gl::Texture mEnvDfg; // the split sum's DFG table (TEX_ENV_DFG)
    gl::Buffer mNoLink; // bound when a light has no linking (the shader declares the buffer)
    gl::Texture mMaskDepth; // every contribution target's depth: the light's footprint (relight_mask.frag)
    // The covered samples' footprint (an environment light's mask), per target layout: the full
    // frame's pixels, a preview's every second pixel, the sample textures (markFootprint).
    gl::Texture mCoverage[3];
    // Deep buffers: the relight passes run once per sample over the sample textures' layout into
    // these (radiance, footprint), and composite_resolve.frag sums each pixel's samples.
    gl::Texture mSampleRadiance, mSampleDepth;
    gl::Framebuffer mSampleFb;
};

} // namespace dfb::engine
