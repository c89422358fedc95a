#pragma once
// The frame from the cached contributions: emission plus each light's image times its rescale
// (additive blending, light linearity; paper 004 section 4.3), kept as a "static" sum of every
// light but the one being edited; then exposure and the view transform into an sRGB8 target, read
// back through a persistently mapped buffer. Also the fences that end each stage.

#include "GBufferTextures.h"
#include "LightCache.h"
#include "ShaderVariants.h"

#include <dfb/core/Result.h>
#include <dfb/gl/Context.h>
#include <dfb/gl/Objects.h>
#include <dfb/server/Engine.h>

#include <map>
#include <string>

namespace dfb::engine {

/// Waits for the GPU to finish what was submitted, at most 20 s: a hung GPU or a lost context
/// becomes a GpuError naming `stage` instead of a hang.
Status waitForGpu(gl::Context& context, const char* stage);

class Compositor {
public:
    Compositor(ShaderVariants& shaders, const GBufferTextures& gbuffer) : mShaders(shaders), mGBuffer(gbuffer) {}

    /// Targets and programs. GL thread.
    Status init();

    /// Sums emission and the enabled lights' contributions (`lights`: their caches, by name) into
    /// the accumulation target, rebuilding the static sum when a new light is being edited. With
    /// `fused`, the usual case of an edit (the static sum valid, one hot light) leaves the sum to
    /// toneMap instead (*fused = true): one full-frame pass instead of three.
    void composite(const Rig& rig, std::map<std::string, LightCache>& lights, bool* fused = nullptr);

    /// Exposure and the view transform of the accumulation (or, `fused`, of the static sum plus
    /// the hot light) into the sRGB target.
    Status toneMap(const Rig& rig, const std::map<std::string, LightCache>& lights, bool fused);

    /// Starts copying the sRGB target's pixels into the read-back buffer; once the GPU has
    /// finished (waitForGpu), readBackPixels returns them, row 0 at the top.
    Status startReadBack();
    Image8 readBackPixels() const;

    /// An image-sized float texture, times `scale` per channel (`what` names it in errors).
    Result<ImageF> readFloat(gl::Context& context, GLuint texture, const char* what, glm::vec3 scale = glm::vec3(1.f)) const;

    /// The linear frame of the last composite without `fused`.
    GLuint accumulation() const { return mAccum.id(); }

private:
    void addLight(const LightCache& c) const;
    void emission() const;

    ShaderVariants& mShaders;
    const GBufferTextures& mGBuffer;
    GLuint mAddProgram = 0, mEmissionProgram = 0, mTonemapProgram = 0; // owned by mShaders
    gl::VertexArray mEmptyVao;
    gl::Texture mAccum, mLdr;
    gl::Framebuffer mAccumFb, mLdrFb;
    // The frame's read-back target: a persistently mapped buffer in client memory, so the pixels
    // arrive by DMA and leave by a parallel copy (glReadPixels to client memory would copy them
    // on one thread inside the driver).
    gl::Buffer mReadback;
    const uint8_t* mReadbackPixels = nullptr;
    // The sum of emission and every enabled light but the one being edited ("hot"), so that an
    // edit of one light costs two composite draws whatever the rig's size (DESIGN section 6).
    gl::Texture mStatic;
    gl::Framebuffer mStaticFb;
    bool mStaticValid = false;
    std::string mHot;
    std::string mStructure; // enabled light names the static sum was built for
};

} // namespace dfb::engine
