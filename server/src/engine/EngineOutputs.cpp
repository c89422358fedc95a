// GlEngine's non-beauty outputs: one light's linear contribution, its shadow mask, the light
// layers and the linear beauty, all read from the per-light caches (Outputs.cpp encodes them for
// requests).

#include "GlEngine.h"

namespace dfb::engine {
namespace {

// Outputs that read single lights' contributions are always full quality, even mid-drag.
struct FullQuality {
    bool& preview;
    bool saved;
    explicit FullQuality(bool& p) : preview(p), saved(p) { preview = false; }
    ~FullQuality() { preview = saved; }
    FullQuality(const FullQuality&) = delete;
    FullQuality& operator=(const FullQuality&) = delete;
};

} // namespace

Result<ImageF> GlEngine::renderLightLinear(const Rig& rig, const std::string& lightName) {
    const Light* l = rig.find(lightName);
    if (!l) return makeError(ErrorCode::MissingData, "no light named '" + lightName + "'");
    FullQuality full(mPreview);
    FrameStats st;
    if (auto s = renderAccumulation(rig, st); !s) return s.error();
    if (!l->enabled) {
        ImageF black;
        black.width = mGBuffer.width;
        black.height = mGBuffer.height;
        black.rgba.assign(size_t(black.width) * size_t(black.height) * 4, 0.f);
        return black;
    }
    const LightCache& c = mLights[lightName];
    return readFloat(c.contribution.id(), "light alone", c.scale);
}

Result<ImageF> GlEngine::renderAreaReference(const Rig& rig, const std::string& lightName, int cells) {
    const Light* l = rig.find(lightName);
    if (!l) return makeError(ErrorCode::MissingData, "no light named '" + lightName + "'");
    if (l->type != LightType::Area) {
        return makeError(ErrorCode::InvalidValue, "light '" + lightName + "' is not an area light: only area lights have a reference");
    }
    if (cells < 1 || cells > MAX_AREA_REFERENCE_CELLS) {
        return makeError(ErrorCode::InvalidValue, "reference cells " + std::to_string(cells) + " out of range 1.." +
                                                      std::to_string(MAX_AREA_REFERENCE_CELLS));
    }
    FullQuality full(mPreview);
    FrameStats st;
    if (auto s = renderAccumulation(rig, st); !s) return s.error(); // its shadow maps
    if (!l->enabled) return makeError(ErrorCode::InvalidValue, "light '" + lightName + "' is disabled");
    LightCache& c = mLights[lightName];
    if (auto s = mShading.shade(c, 0, false, cells); !s) return s.error();
    if (auto s = waitGpu("area reference"); !s) return s.error();
    c.hasContribution = false; // the next frame re-shades one-shot (and rebuilds the sums that hold it)
    ++c.version;
    return readFloat(c.contribution.id(), "area light reference", c.scale);
}

Result<ImageF> GlEngine::renderShadowMask(const Rig& rig, const std::string& lightName) {
    const Light* l = rig.find(lightName);
    if (!l) return makeError(ErrorCode::MissingData, "no light named '" + lightName + "'");
    FullQuality full(mPreview);
    FrameStats st;
    if (auto s = renderAccumulation(rig, st); !s) return s.error(); // brings the light's shadow map up to date
    if (!l->enabled) return makeError(ErrorCode::InvalidValue, "light '" + lightName + "' is disabled");
    LightCache& c = mLights[lightName];
    // Shade the mask into the light's contribution target, then mark the contribution stale.
    if (auto s = mShading.shade(c, 1, mPreview); !s) return s.error();
    c.hasContribution = false; // the next frame re-shades it (and rebuilds the sums that hold it)
    ++c.version;
    return readFloat(c.contribution.id(), "shadow mask");
}

Result<std::vector<NamedImageF>> GlEngine::renderLayers(const Rig& rig) {
    FullQuality full(mPreview);
    FrameStats st;
    if (auto s = renderAccumulation(rig, st); !s) return s.error();
    std::vector<NamedImageF> layers;
    auto beauty = readLinearBeauty("beauty layer");
    if (!beauty) return beauty.error();
    layers.push_back({"", std::move(beauty.value())});
    for (const Light& l : rig.lights) {
        if (!l.enabled) continue;
        const LightCache& c = mLights[l.name];
        auto img = readFloat(c.contribution.id(), "light layer", c.scale);
        if (!img) return img.error();
        layers.push_back({l.name, std::move(img.value())});
    }
    return layers;
}

// The accumulation's alpha is whatever the blending left there (1 after a full composite, 0 after
// an incremental one that added a light to the cached sum): the linear beauty is opaque, alpha 1,
// whichever path made it.
Result<ImageF> GlEngine::readLinearBeauty(const char* what) {
    auto beauty = readFloat(mCompositor.accumulation(), what);
    if (!beauty) return beauty.error();
    for (size_t i = 3; i < beauty->rgba.size(); i += 4) beauty->rgba[i] = 1.f;
    return beauty;
}

Result<ImageF> GlEngine::renderLinear(const Rig& rig) {
    FrameStats st;
    if (auto s = renderAccumulation(rig, st); !s) return s.error();
    return readLinearBeauty("relight frame (linear)");
}

} // namespace dfb::engine
