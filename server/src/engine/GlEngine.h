#pragma once
// The GL implementation of Engine (DESIGN section 6): G-buffer textures uploaded once, per-light
// cached shadow maps and float contribution images, a sum of contributions (light linearity,
// paper 004 section 4.3) plus emission, then exposure and sRGB. GlEngine.cpp orchestrates the
// stages, which live in their own files (docs/architecture.md, "The engine").

#include "CasterAnalysis.h"
#include "Compositing.h"
#include "Cookies.h"
#include "GBufferTextures.h"
#include "LightCache.h"
#include "LightShading.h"
#include "ShaderVariants.h"
#include "ShadowMaps.h"
#include "UniformBuffer.h"

#include <dfb/gl/Context.h>
#include <dfb/server/Engine.h>

#include <algorithm>
#include <map>
#include <memory>
#include <optional>
#include <string>

namespace dfb::engine {

class GlEngine final : public Engine {
public:
    // GL objects are released by the members' destructors: into this engine's own context.
    ~GlEngine() override {
        if (mContext) (void)mContext->makeCurrent();
    }
    Status init(const DeepBuffer& g, const ShadowGeometry& casters);
    Result<Image8> render(const Rig& rig, FrameStats* stats) override;
    Result<ImageF> renderLinear(const Rig& rig) override;
    Result<ImageF> renderShadowMask(const Rig& rig, const std::string& lightName) override;
    Result<ImageF> renderLightLinear(const Rig& rig, const std::string& lightName) override;
    Result<ImageF> renderAreaReference(const Rig& rig, const std::string& lightName, int cells) override;
    Result<std::vector<NamedImageF>> renderLayers(const Rig& rig) override;
    std::string deviceDescription() const override { return mContext->description(); }
    int width() const override { return mGBuffer.width; }
    void setShadowSubdivisionLimit(int maxLevel) override { mSubdivisionLimit = std::clamp(maxLevel, 1, 64); }
    int height() const override { return mGBuffer.height; }
    void setAssetDirectory(std::string dir) override { mCookies.setDirectory(std::move(dir)); }
    void setPreview(bool preview) override { mPreview = preview; }

private:
    Status renderAccumulation(const Rig& rig, FrameStats& st, bool* fused = nullptr);
    Status updateShadows(const Rig& rig, FrameStats& st);
    Status updateContributions(const Rig& rig, FrameStats& st);
    Status waitGpu(const char* stage);
    Result<ImageF> readFloat(GLuint texture, const char* what, glm::vec3 scale = glm::vec3(1.f));
    Result<ImageF> readLinearBeauty(const char* what); ///< the accumulation, alpha 1

    // First: destroyed last, after every GL object below.
    std::unique_ptr<gl::Context> mContext;
    bool mPreview = false;
    int mSubdivisionLimit = 64;
    // Set when the GPU hung or the context was lost: every later call returns it at once (the
    // context cannot be trusted again; the server must create a new engine).
    std::optional<Error> mFailure;
    glm::vec3 mCameraPosition{0.f}, mCameraForward{0.f, 0.f, -1.f};
    glm::vec3 mCameraRight{1.f, 0.f, 0.f}, mCameraDown{0.f, -1.f, 0.f};
    // A pixel's height at unit depth (perspective) or in scene units (orthographic).
    float mPixelSize = 0.f;
    bool mOrthographic = false;

    ShaderVariants mShaders;
    GBufferTextures mGBuffer;
    Casters mCasters;
    LightUniforms mLightUniforms;
    ViewUniforms mViewUniforms;
    Cookies mCookies;
    ShadowMaps mShadows{mShaders, mCasters, mLightUniforms};
    LightShading mShading{mShaders, mGBuffer, mLightUniforms, mCookies};
    Compositor mCompositor{mShaders, mGBuffer};
    std::map<std::string, LightCache> mLights;
};

} // namespace dfb::engine
