// Engine::create and GlEngine's frame: per light, bring its shadow map and contribution up to
// date with the rig (or rescale the cached contribution), then composite, tone map and read back,
// with a fence at each stage boundary. The stages are in ShadowMaps, LightShading and Compositing;
// the non-beauty outputs in EngineOutputs.cpp.

#include "GlEngine.h"

#include "CacheKeys.h"
#include "GpuInterface.h"

#include <bit>
#include <chrono>
#include <cmath>

namespace dfb::engine {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

} // namespace

Status GlEngine::init(const DeepBuffer& g, const ShadowGeometry& casters) {
    if (g.width <= 0 || g.height <= 0 || g.sampleOffset.size() != g.pixelCount() + 1) {
        return makeError(ErrorCode::InvalidValue, "engine: empty or inconsistent deep buffer");
    }
    auto ctx = gl::Context::create();
    if (!ctx) return ctx.error();
    mContext = std::move(ctx.value());
    // An environment's prefiltered map is a cube map, read across its faces' edges
    // (relight_env.frag prefiltered).
    glEnable(GL_TEXTURE_CUBE_MAP_SEAMLESS);
    mCameraPosition = g.camera.position();
    mCameraForward = g.camera.forward();
    mOrthographic = g.camera.orthographic;
    const glm::mat4 cameraToWorld = glm::inverse(g.camera.worldToCamera);
    mCameraRight = glm::normalize(glm::vec3(cameraToWorld[0]));
    mCameraDown = -glm::normalize(glm::vec3(cameraToWorld[1]));
    // Pixels are square (aspect = width / height): one row of 2 tan(yfov / 2) / H at unit depth.
    mPixelSize = g.camera.orthographic ? 2.f * g.camera.ymag / float(g.height)
                                       : 2.f * std::tan(0.5f * g.camera.yfovRadians) / float(g.height);
    if (auto s = mGBuffer.upload(g); !s) return s;
    mShaders.configure(mGBuffer.flat);
    mCasters.upload(casters, g);
    if (auto s = mShadows.init(); !s) return s;
    if (auto s = mShading.init(); !s) return s;
    if (auto s = mCompositor.init(); !s) return s;
    return mContext->check("engine initialisation");
}

// Waits for the stage's GPU work; a failure is kept and refuses every later call.
Status GlEngine::waitGpu(const char* stage) {
    Status s = waitForGpu(*mContext, stage);
    if (!s) mFailure = s.error();
    return s;
}

// Lights whose shadow inputs changed get a new map (and must be re-shaded).
Status GlEngine::updateShadows(const Rig& rig, FrameStats& st) {
    for (const Light& l : rig.lights) {
        if (!l.enabled) continue;
        LightCache& c = mLights[l.name];
        // An environment light has no shadow map of its own: its visibility is the shot's
        // (relight_env.frag). Its map's suns and lamps, if it has any, are directional lights
        // with sharp shadow maps (c.interior[k], EnvironmentMap.h extractSuns), shaded in its
        // own pass (LightShading).
        if (l.type == LightType::Environment) {
            if (c.hasShadow || !sameShadowInputs(c.params, l)) {
                c.shadowMap = {};
                c.hasShadow = false;
                c.shadowTarget = GL_NONE;
                c.hasContribution = false;
            }
            auto env = mCookies.environment(l);
            if (!env) return env.error();
            if (c.interior.size() != env->suns.size()) {
                c.interior.clear();
                c.interior.resize(env->suns.size());
                c.hasContribution = false;
            }
            for (size_t k = 0; k < env->suns.size(); ++k) {
                const Light sun = environmentSun(l, env->suns[k].direction, int(k));
                LightCache& s = c.interior[k];
                s.sunCasters = true;
                const bool first = s.params.name != sun.name;
                if (sun.shadow && (first || !s.hasShadow || !sameShadowInputs(s.params, sun) || (!mPreview && s.previewShadow))) {
                    s.params = sun;
                    if (auto r = mShadows.render(s, mPreview, mSubdivisionLimit); !r) return r;
                    ++st.shadowMapsRendered;
                    st.shadowCasterTriangles += s.casterIndexCount / 3;
                    c.hasContribution = false;
                } else if (first || !sameShadowInputs(s.params, sun) || !sameShadingInputs(s.params, sun)) {
                    s.params = sun;
                    s.worldToLightClip = lightViewProj(sun, mCasters.scene(), mCasters.receivers());
                    if (!sun.shadow) s.hasShadow = false;
                    c.hasContribution = false;
                }
            }
            continue;
        }
        const bool shadowValid = c.hasShadow && sameShadowInputs(c.params, l) && (mPreview || !c.previewShadow) &&
                                 ((l.type != LightType::Bendy && l.type != LightType::BentArea) ||
                                  c.subdivisionLimit == mSubdivisionLimit);
        if (l.shadow && !shadowValid) {
            c.params = l;
            c.hasContribution = false;
            if (auto s = mShadows.render(c, mPreview, mSubdivisionLimit); !s) return s;
            ++st.shadowMapsRendered;
            st.shadowCasterTriangles += c.casterIndexCount / 3;
            if ((l.type == LightType::Bendy || l.type == LightType::BentArea) && c.appliedSubdivision < mSubdivisionLimit)
                ++st.subdivisionLowered;
        } else if (!l.shadow && !sameShadowInputs(c.params, l)) {
            c.worldToLightClip = lightViewProj(l, mCasters.scene(), mCasters.receivers());
            c.hasShadow = false;
            c.hasContribution = false;
        }
    }
    return okStatus();
}

// Lights whose shading inputs changed are re-shaded; colour or intensity edits only change the
// factor their unit-radiance contribution is composited with.
Status GlEngine::updateContributions(const Rig& rig, FrameStats& st) {
    for (const Light& l : rig.lights) {
        if (!l.enabled) continue;
        LightCache& c = mLights[l.name];
        if (c.hasContribution && sameShadingInputs(c.params, l) && (mPreview || !c.previewShading)) {
            // Shaded at unit radiance: colour x intensity is only the factor it is composited with.
            const glm::vec3 scale = radiance(l);
            if (scale != c.scale) {
                c.scale = scale;
                ++c.version;
            }
            c.params = l;
            continue;
        }
        c.params = l;
        if (auto s = mShading.shade(c, 0, mPreview); !s) return s;
        ++st.lightsShaded;
    }
    return okStatus();
}

// Shadow maps, shading and the sum of the contributions (Compositor::composite, `fused` as there).
Status GlEngine::renderAccumulation(const Rig& rig, FrameStats& st, bool* fused) {
    if (mFailure) return *mFailure;
    if (auto s = mContext->makeCurrent(); !s) return s;
    ViewBlock view{};
    view.cameraPosition = glm::vec4(mCameraPosition, mOrthographic ? 1.f : 0.f);
    view.cameraForward = glm::vec4(mCameraForward, 0.f);
    view.exposure = glm::vec4(std::exp2(rig.exposureStops), rig.viewTransform == ViewTransform::Filmic ? 1.f : 0.f, 0, 0);
    view.sampleLayout = glm::ivec4(mGBuffer.sampleRow, std::countr_zero(unsigned(mGBuffer.sampleRow)),
                                   mGBuffer.footprintTaps, 0);
    view.cameraRight = glm::vec4(mCameraRight, mPixelSize);
    view.cameraDown = glm::vec4(mCameraDown, 0.f);
    for (size_t i = 0; i < mGBuffer.footprintOffsets.size(); ++i) {
        // Two taps per vec4: tap 2k in xy, tap 2k + 1 in zw.
        const glm::vec2 o = mGBuffer.footprintOffsets[i];
        view.footprintTaps[i / 2][int(2 * (i % 2))] = o.x;
        view.footprintTaps[i / 2][int(2 * (i % 2) + 1)] = o.y;
    }
    mViewUniforms.upload(view);

    // Forget lights that left the rig (their GL objects are released here).
    for (auto it = mLights.begin(); it != mLights.end();) {
        it = rig.find(it->first) ? std::next(it) : mLights.erase(it);
    }

    auto t = Clock::now();
    if (auto s = updateShadows(rig, st); !s) return s;
    if (auto s = waitGpu("shadow maps"); !s) return s;
    st.shadowMs = msSince(t);

    t = Clock::now();
    if (auto s = updateContributions(rig, st); !s) return s;
    if (auto s = waitGpu("shading"); !s) return s;
    st.shadeMs = msSince(t);

    t = Clock::now();
    mCompositor.composite(rig, mLights, fused);
    if (auto s = waitGpu("composite"); !s) return s;
    st.compositeMs = msSince(t);
    return okStatus();
}

Result<Image8> GlEngine::render(const Rig& rig, FrameStats* stats) {
    FrameStats local;
    FrameStats& st = stats ? *stats : local;
    st = FrameStats{};
    bool fused = false;
    if (auto s = renderAccumulation(rig, st, &fused); !s) return s.error();
    auto t = Clock::now();
    if (auto s = mCompositor.toneMap(rig, mLights, fused); !s) return s.error();
    if (auto s = waitGpu("view transform"); !s) return s.error();
    st.compositeMs += msSince(t); // the view transform belongs to the composite stage

    t = Clock::now();
    if (auto s = mCompositor.startReadBack(); !s) return s.error();
    if (auto s = waitGpu("read-back"); !s) return s.error();
    Image8 img = mCompositor.readBackPixels();
    st.readbackMs = msSince(t);
    if (auto s = mContext->check("relight frame"); !s) return s.error();
    return img;
}

Result<ImageF> GlEngine::readFloat(GLuint texture, const char* what, glm::vec3 scale) {
    return mCompositor.readFloat(*mContext, texture, what, scale);
}

} // namespace dfb::engine

namespace dfb {

Result<std::unique_ptr<Engine>> Engine::create(const DeepBuffer& gbuffer, const ShadowGeometry& casters) {
    auto e = std::make_unique<engine::GlEngine>();
    if (auto s = e->init(gbuffer, casters); !s) return s.error();
    return std::unique_ptr<Engine>(std::move(e));
}

} // namespace dfb
