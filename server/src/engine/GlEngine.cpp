// The GL implementation of Engine (DESIGN section 6): G-buffer textures uploaded once, per-light
// cached shadow maps and float contribution images, a sum of contributions (light linearity,
// paper 004 section 4.3) plus emission, then exposure and sRGB.

#include <dfb/server/Engine.h>

#include "GpuInterface.h"
#include "WorkerPool.h"

#include <dfb/server/BendyChain.h>

#include <dfb/gl/Context.h>
#include <dfb/gl/Objects.h>

#include <glm/gtc/matrix_transform.hpp>

#include <dfb/server/ImageCodec.h>

#include <malloc.h> // mallopt (glibc): keepFreedMemoryForFrames

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <string_view>
#include <tuple>
#include <unordered_map>

namespace dfb::shaders {
std::string_view serverShader(std::string_view name);
}

namespace dfb {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

glm::vec3 toGlm(const Vec3& v) { return {v[0], v[1], v[2]}; }

// Half-angle of a light's shadow frustum, degrees: the cone plus a degree, rounded up to 5 degrees
// so that dragging a spot light's cone re-shades without re-rendering its shadow map until it
// crosses a step (a BendyLight's deformed geometry depends on the exact cone, so its map is
// re-rendered on every cone edit anyway). At most 86: a perspective projection degenerates
// towards 90. Documented in docs/lighting.md (tests compute the receiver bias with it).
float shadowHalfAngleDeg(const Light& l) {
    return std::min(5.f * std::ceil((l.coneAngleDeg + 1.f) / 5.f), 86.f);
}

// What a light's shadow map depends on; any difference re-renders it.
bool sameShadowInputs(const Light& a, const Light& b) {
    if (a.type == LightType::Point || b.type == LightType::Point) {
        // Omnidirectional: direction and cone play no part in a cube map.
        return a.type == b.type && a.position == b.position && a.shadow == b.shadow && a.shadowMapSize == b.shadowMapSize;
    }
    return a.position == b.position && a.direction == b.direction && shadowHalfAngleDeg(a) == shadowHalfAngleDeg(b) &&
           (a.type != LightType::Bendy || a.coneAngleDeg == b.coneAngleDeg) &&
           a.shadow == b.shadow && a.shadowMapSize == b.shadowMapSize && a.type == b.type &&
           (a.type != LightType::Bendy || (a.controlPoints == b.controlPoints && a.radii == b.radii));
}

// What a light's contribution image depends on, besides its shadow map. Colour and intensity are
// not among them: they only rescale the cached image.
bool sameShadingInputs(const Light& a, const Light& b) {
    return sameShadowInputs(a, b) && a.coneAngleDeg == b.coneAngleDeg && a.penumbraDeg == b.penumbraDeg && a.shadowBias == b.shadowBias && a.type == b.type &&
           a.include == b.include && a.exclude == b.exclude && a.shadowFilter == b.shadowFilter &&
           a.cookie == b.cookie && a.barnDoorsDeg == b.barnDoorsDeg &&
           (a.type != LightType::Bendy || (a.colors == b.colors && a.exactDirection == b.exactDirection));
}

struct LightCache {
    Light params;
    bool hasShadow = false;
    bool hasContribution = false;
    bool shadowIsCube = false;     // a point light's cube map (GL_TEXTURE_CUBE_MAP)
    bool previewShadow = false;    // rendered at preview size: re-render at full size when refining
    bool previewShading = false;   // contribution shaded at half resolution (top-left quarter)
    glm::vec2 cubeNearFar{0.f};    // the cube faces' projection planes
    int shadowSize = 0;
    gl::Texture shadowMap;
    gl::Framebuffer shadowFb;
    gl::Texture contribution;
    gl::Framebuffer contributionFb;
    glm::mat4 worldToLightClip{1.f};
    gl::Buffer bendyUbo; // BendyBlock of a BendyLight
    lightmath::Chain<float> chain; // its chain as last uploaded,
    engine::BendyBlock bendy{};    // and as the shaders see it (segments: the variants' BENDY_K)
    int bendySegments() const { return int(bendy.axisV.w + 0.5f); }
    GLsizei casterIndexCount = 0; // casterIndices() when its shadow map was last rendered
    gl::Buffer linkMask; // light linking: one bit per object id
    int subdivisionLimit = 0; // the limit its deformed shadow map was rendered with
    glm::vec3 shadedRadiance{0.f}; // colour x intensity the contribution was shaded with
    glm::vec3 scale{1.f};          // current colour x intensity / shadedRadiance
    uint64_t version = 0;          // bumped whenever the contribution or its scale changes
    uint64_t compositedVersion = ~0ull;
};

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
    Result<std::vector<NamedImageF>> renderLayers(const Rig& rig) override;
    std::string deviceDescription() const override { return mContext->description(); }
    int width() const override { return mWidth; }
    void setShadowSubdivisionLimit(int maxLevel) override { mSubdivisionLimit = std::clamp(maxLevel, 1, 64); }
    int height() const override { return mHeight; }
    void setAssetDirectory(std::string dir) override { mAssetDir = std::move(dir); }
    void setPreview(bool preview) override { mPreview = preview; }

private:
    Result<gl::Program> program(const char* vert, const char* frag);
    std::string specialise(std::string_view source, const std::string& defines) const;
    Result<GLuint> variant(const std::vector<const char*>& stages, const std::string& defines);
    std::string shadeDefines(const LightCache& c, int output, bool cookie, bool linked) const;
    glm::mat4 lightViewProj(const Light& l) const;
    void uploadBendy(LightCache& c);
    Status renderShadow(LightCache& c);
    Status renderCubeShadow(LightCache& c);
    void drawCasters(GLsizei count, const glm::mat4& worldToClip);
    GLsizei casterIndices(const LightCache& c) const;
    Result<GLuint> cookieTexture(const Light& l);
    Status waitGpu(const char* stage);
    Status shade(LightCache& c, int output = 0);
    Status renderAccumulation(const Rig& rig, FrameStats& st, bool* fused = nullptr);
    Result<ImageF> readFloat(GLuint texture, const char* what, glm::vec3 scale = glm::vec3(1.f));

    std::unique_ptr<gl::Context> mContext;
    std::string mAssetDir = ".";
    std::map<std::string, gl::Texture> mCookies; // by file name, loaded on first use
    bool mPreview = false;
    // Set when the GPU hung or the context was lost: every later call returns it at once (the
    // context cannot be trusted again; the server must create a new engine).
    std::optional<Error> mFailure;
    int mWidth = 0, mHeight = 0;
    glm::vec3 mCameraPosition{0.f}, mCameraForward{0.f, 0.f, -1.f};
    bool mOrthographic = false;
    bool mFlat = false; // one sample per pixel, stored at the pixel: specialised shaders
    bool mHasSheen = false, mHasCoat = false; // any sample with a sheen / clear-coat lobe
    // Shader variants specialised per light configuration (common_uniforms.glsl,
    // "Specialisation"), compiled on first use: by stage file names and defines.
    std::map<std::string, gl::Program> mVariants;
    // DFB_GENERIC_SHADERS=1: no variants, no footprint pre-pass (a diagnostic, and the reference
    // the specialised path is tested against).
    bool mGeneric = false;
    int mSampleRow = 0;
    glm::vec3 mSceneMin{0.f}, mSceneMax{0.f};
    glm::vec3 mReceiverMin{0.f}, mReceiverMax{0.f}; // bounds of the shot's covered samples
    gl::Texture mP, mN, mNg, mAlbedo, mBrdf, mEmission, mSheen, mCoat, mPixelSamples, mIds;
    uint32_t mMaxObjectId = 0;
    gl::Buffer mNoLink; // bound when a light has no linking (the shader declares the buffer)
    gl::Buffer mCasterVbo, mCasterIbo;
    gl::VertexArray mCasterVao, mEmptyVao;
    GLsizei mCasterIndexCount = 0;
    GLsizei mClosedIndexCount = 0; // indices[0, this) are closed meshes (ShadowGeometry)
    std::vector<ShadowGeometry::Part> mParts; // the meshes' index ranges and boxes, in index order
    GLsizei mPlanarStart = 0;      // indices[this, end) are open planar meshes, with these planes:
    std::vector<glm::vec4> mPlanes; // oriented so that every receiver is on the positive side
    bool mPlanesSkippable = false;  // ... which holds for all of them (else never left out)
    gl::Buffer mLightUbo, mViewUbo;
    gl::Program mShadowProgram, mAddProgram, mEmissionProgram, mTonemapProgram, mResolveProgram;
    gl::Program mBendyClassifyProgram, mBendyFlatProgram;
    gl::Buffer mFlatIndices, mTessIndices, mIndirect; // triangle lists sorted by bendy_classify.comp
    gl::VertexArray mFlatVao, mTessVao;
    gl::Buffer mDeformed; // 2 vec4 per caster vertex (bendy_deform.comp)
    gl::Texture mDeformedTexture, mCasterIndexTexture; // buffer textures of mDeformed and mCasterIbo
    GLuint mCasterVertexCount = 0;
    int mSubdivisionLimit = 64;
    gl::Texture mAccum, mLdr;
    // The frame's read-back target: a persistently mapped buffer in client memory, so the pixels
    // arrive by DMA and leave by a parallel copy (glReadPixels to client memory would copy them
    // on one thread inside the driver).
    gl::Buffer mReadback;
    const uint8_t* mReadbackPixels = nullptr;
    gl::Texture mMaskDepth; // every contribution target's depth: the light's footprint (relight_mask.frag)
    // Deep buffers: the relight passes run once per sample over the sample textures' layout into
    // these (radiance, footprint), and composite_resolve.frag sums each pixel's samples.
    gl::Texture mSampleRadiance, mSampleDepth;
    gl::Framebuffer mSampleFb;
    int mSampleRows = 0;
    gl::Framebuffer mAccumFb, mLdrFb;
    std::map<std::string, LightCache> mLights;
    // The sum of emission and every enabled light but the one being edited ("hot"), so that an
    // edit of one light costs two composite draws whatever the rig's size (DESIGN section 6).
    gl::Texture mStatic;
    gl::Framebuffer mStaticFb;
    bool mStaticValid = false;
    std::string mHot;
    std::string mStructure; // enabled light names the static sum was built for
};

// Inserts `defines` after the #version line; flat buffers also get DFB_FLAT_SAMPLES.
std::string GlEngine::specialise(std::string_view source, const std::string& defines) const {
    std::string out(source);
    const size_t eol = out.find('\n');
    out.insert(eol == std::string::npos ? out.size() : eol + 1, (mFlat ? "#define DFB_FLAT_SAMPLES 1\n" : "") + defines);
    return out;
}

Result<gl::Program> GlEngine::program(const char* vert, const char* frag) {
    return gl::buildProgram({{GL_VERTEX_SHADER, vert, specialise(shaders::serverShader(vert), "")},
                             {GL_FRAGMENT_SHADER, frag, specialise(shaders::serverShader(frag), "")}});
}

// A program of the given stage files (the stage from each name's extension) with `defines`,
// built once and kept.
Result<GLuint> GlEngine::variant(const std::vector<const char*>& stages, const std::string& defines) {
    std::string key = defines;
    for (const char* s : stages) key += std::string("|") + s;
    if (auto it = mVariants.find(key); it != mVariants.end()) return it->second.id();
    std::vector<std::string> texts; // ShaderSource holds views: keep the texts alive
    texts.reserve(stages.size());
    std::vector<gl::ShaderSource> sources;
    for (const char* name : stages) {
        const std::string_view n(name);
        const GLenum stage = n.ends_with(".vert")   ? GL_VERTEX_SHADER
                             : n.ends_with(".tesc") ? GL_TESS_CONTROL_SHADER
                             : n.ends_with(".tese") ? GL_TESS_EVALUATION_SHADER
                             : n.ends_with(".comp") ? GL_COMPUTE_SHADER
                                                    : GL_FRAGMENT_SHADER;
        texts.push_back(specialise(shaders::serverShader(name), defines));
        sources.push_back({stage, name, texts.back()});
    }
    auto p = gl::buildProgram(sources);
    if (!p) return p.error();
    const GLuint id = p->id();
    mVariants.emplace(std::move(key), std::move(p.value()));
    return id;
}

// The relight shaders' specialisation for this light (see common_uniforms.glsl): every define
// fixes a path the light takes or cannot take, so each variant computes what the generic shader
// would, without the others' cost.
std::string GlEngine::shadeDefines(const LightCache& c, int output, bool cookie, bool linked) const {
    if (mGeneric) return "";
    const Light& l = c.params;
    std::string d;
    auto def = [&d](const char* name, const std::string& value) { d += std::string("#define ") + name + " " + value + "\n"; };
    auto flag = [&def](const char* name, bool on) { def(name, on ? "true" : "false"); };
    def("SHADE_KIND", l.type == LightType::Directional ? "0" : l.type == LightType::Point ? "2" : "1");
    flag("SHADE_SHADOWED", l.shadow);
    def("SHADE_PCF_RADIUS", std::to_string(l.shadowFilter));
    flag("SHADE_COOKIE", cookie);
    bool doors = false;
    for (float a : l.barnDoorsDeg) doors = doors || a < 90.f;
    flag("SHADE_DOORS", l.type == LightType::Spot && doors);
    flag("SHADE_LINKED", linked);
    def("SHADE_OUTPUT", std::to_string(output));
    flag("SHADE_SHEEN", mHasSheen);
    flag("SHADE_COAT", mHasCoat);
    if (l.type == LightType::Bendy) {
        def("BENDY_K", std::to_string(c.bendySegments()));
        flag("BENDY_EXACT", l.exactDirection);
    }
    return d;
}

// Uploads one per-sample layer into a sample texture (see common_uniforms.glsl for the layout),
// padded to RGBA (three-component float textures are slow paths on some drivers).
gl::Texture uploadLayer(GLenum internalFormat, int row, int rows, const std::vector<float>& data, int comps,
                        const std::vector<float>* alpha) {
    const size_t n = data.size() / size_t(comps);
    std::vector<float> rgba(size_t(row) * size_t(rows) * 4, 0.f);
    for (size_t i = 0; i < n; ++i) {
        for (int c = 0; c < comps; ++c) rgba[i * 4 + size_t(c)] = data[i * size_t(comps) + size_t(c)];
        if (alpha) rgba[i * 4 + 3] = (*alpha)[i];
    }
    gl::Texture t = gl::makeTexture2D(internalFormat, row, rows);
    glTextureSubImage2D(t.id(), 0, 0, 0, row, rows, GL_RGBA, GL_FLOAT, rgba.data());
    return t;
}

// A vertex array of vec3 positions (ATTR_POSITION) drawn through an index buffer.
gl::VertexArray positionVao(const gl::Buffer& positions, const gl::Buffer& indices) {
    GLuint vao = 0;
    glCreateVertexArrays(1, &vao);
    glVertexArrayVertexBuffer(vao, 0, positions.id(), 0, sizeof(glm::vec3));
    glVertexArrayElementBuffer(vao, indices.id());
    glEnableVertexArrayAttrib(vao, engine::ATTR_POSITION);
    glVertexArrayAttribFormat(vao, engine::ATTR_POSITION, 3, GL_FLOAT, GL_FALSE, 0);
    glVertexArrayAttribBinding(vao, engine::ATTR_POSITION, 0);
    return gl::VertexArray(vao);
}

Status GlEngine::init(const DeepBuffer& g, const ShadowGeometry& casters) {
    if (g.width <= 0 || g.height <= 0 || g.sampleOffset.size() != g.pixelCount() + 1) {
        return makeError(ErrorCode::InvalidValue, "engine: empty or inconsistent deep buffer");
    }
    auto ctx = gl::Context::create();
    if (!ctx) return ctx.error();
    mContext = std::move(ctx.value());
    mWidth = g.width;
    mHeight = g.height;
    mCameraPosition = g.camera.position();
    mCameraForward = g.camera.forward();
    mOrthographic = g.camera.orthographic;
    mFlat = g.isFlat();
    if (const char* generic = std::getenv("DFB_GENERIC_SHADERS")) mGeneric = *generic && std::string_view(generic) != "0";

    // Sample textures: as wide as the image (so a flat buffer's sample texture is the image); a
    // deep buffer's are a power of two wide (sampleTexel: a mask and a shift), wider still when
    // its rows would exceed GL's minimum maximum texture size.
    constexpr int MAX_SIDE = 16384;
    const size_t samples = std::max<size_t>(g.sampleCount(), 1);
    mSampleRow = mFlat ? mWidth : std::min(int(std::bit_ceil(unsigned(std::max(mWidth, 1)))), MAX_SIDE);
    if ((samples + size_t(mSampleRow) - 1) / size_t(mSampleRow) > size_t(MAX_SIDE)) mSampleRow = MAX_SIDE;
    const int rows = int((samples + size_t(mSampleRow) - 1) / size_t(mSampleRow));
    mSampleRows = rows;
    if (rows > MAX_SIDE) return makeError(ErrorCode::InvalidValue, "engine: too many samples for the GPU's textures");
    mFlat = mFlat && mSampleRow == mWidth; // the flat shaders read sample (x, y) at pixel (x, y)
    mP = uploadLayer(GL_RGBA32F, mSampleRow, rows, g.P, 3, &g.A);
    mN = uploadLayer(GL_RGBA16F, mSampleRow, rows, g.N, 3, nullptr);
    mNg = uploadLayer(GL_RGBA16F, mSampleRow, rows, g.Ng, 3, nullptr);
    mAlbedo = uploadLayer(GL_RGBA16F, mSampleRow, rows, g.albedo, 3, nullptr);
    mBrdf = uploadLayer(GL_RGBA16F, mSampleRow, rows, g.brdf, 4, nullptr);
    mEmission = uploadLayer(GL_RGBA16F, mSampleRow, rows, g.emission, 3, nullptr);
    mSheen = uploadLayer(GL_RGBA16F, mSampleRow, rows, g.sheen, 4, nullptr);
    mCoat = uploadLayer(GL_RGBA16F, mSampleRow, rows, g.coat, 2, nullptr);
    for (size_t i = 0; i < g.sampleCount() && !mHasSheen; ++i) {
        mHasSheen = g.sheen[i * 4] > 0.f || g.sheen[i * 4 + 1] > 0.f || g.sheen[i * 4 + 2] > 0.f;
    }
    for (size_t i = 0; i < g.sampleCount() && !mHasCoat; ++i) mHasCoat = g.coat[i * 2] > 0.f;
    {
        std::vector<uint32_t> ids(size_t(mSampleRow) * size_t(rows), 0);
        for (size_t i = 0; i < g.sampleCount(); ++i) {
            ids[i] = g.objectId[i];
            mMaxObjectId = std::max(mMaxObjectId, g.objectId[i]);
        }
        mIds = gl::makeTexture2D(GL_R32UI, mSampleRow, rows);
        glTextureSubImage2D(mIds.id(), 0, 0, 0, mSampleRow, rows, GL_RED_INTEGER, GL_UNSIGNED_INT, ids.data());
    }
    // Per pixel: first sample and count. Row 0 of the deep buffer (top) goes to GL row 0: every
    // pass is per pixel, so the image is rendered top-down and read back without a flip.
    std::vector<uint32_t> ranges(g.pixelCount() * 2);
    for (size_t p = 0; p < g.pixelCount(); ++p) {
        ranges[p * 2] = g.sampleOffset[p];
        ranges[p * 2 + 1] = g.sampleOffset[p + 1] - g.sampleOffset[p];
    }
    mPixelSamples = gl::makeTexture2D(GL_RG32UI, mWidth, mHeight);
    glTextureSubImage2D(mPixelSamples.id(), 0, 0, 0, mWidth, mHeight, GL_RG_INTEGER, GL_UNSIGNED_INT, ranges.data());

    // Shadow casters.
    mSceneMin = glm::vec3(1e30f);
    mSceneMax = glm::vec3(-1e30f);
    for (const glm::vec3& p : casters.positions) {
        mSceneMin = glm::min(mSceneMin, p);
        mSceneMax = glm::max(mSceneMax, p);
    }
    // Receivers bound the scene too (a shot may be relit with fewer casters than it shows).
    mReceiverMin = glm::vec3(1e30f);
    mReceiverMax = glm::vec3(-1e30f);
    for (size_t i = 0; i < g.sampleCount(); ++i) {
        if (g.A[i] <= 0.f) continue;
        glm::vec3 p(g.P[i * 3], g.P[i * 3 + 1], g.P[i * 3 + 2]);
        mSceneMin = glm::min(mSceneMin, p);
        mSceneMax = glm::max(mSceneMax, p);
        mReceiverMin = glm::min(mReceiverMin, p);
        mReceiverMax = glm::max(mReceiverMax, p);
    }
    if (mReceiverMin.x > mReceiverMax.x) mReceiverMin = mReceiverMax = glm::vec3(0.f);
    if (mSceneMin.x > mSceneMax.x) mSceneMin = mSceneMax = glm::vec3(0.f);
    // Zero-sized buffer storage is a GL error: a shot without casters gets one dummy element.
    const glm::vec3 dummyVertex(0.f);
    const uint32_t dummyIndex = 0;
    mCasterVbo = casters.positions.empty() ? gl::makeBuffer(&dummyVertex, sizeof dummyVertex)
                                           : gl::makeBuffer(casters.positions.data(), casters.positions.size() * sizeof(glm::vec3));
    mCasterIbo = casters.indices.empty() ? gl::makeBuffer(&dummyIndex, sizeof dummyIndex)
                                         : gl::makeBuffer(casters.indices.data(), casters.indices.size() * sizeof(uint32_t));
    mCasterIndexCount = GLsizei(casters.indices.size());
    mClosedIndexCount = GLsizei(std::min(casters.closedIndexCount, casters.indices.size()) / 3 * 3);
    mPlanarStart = GLsizei(std::clamp(casters.planarIndexStart, size_t(mClosedIndexCount), casters.indices.size()) / 3 * 3);
    mParts = casters.parts;
    for (const ShadowGeometry::Part& part : mParts) {
        if (part.firstIndex % 3 || part.indexCount % 3 || part.firstIndex + part.indexCount > casters.indices.size()) {
            mParts.clear(); // not whole triangles in range: draw everything, uncut
            break;
        }
    }
    if (mParts.empty() && !casters.indices.empty()) {
        ShadowGeometry::Part all;
        all.indexCount = casters.indices.size() / 3 * 3;
        all.min = glm::vec3(-std::numeric_limits<float>::infinity());
        all.max = glm::vec3(std::numeric_limits<float>::infinity());
        mParts.push_back(all);
    }
    mPlanes = casters.planes;
    mPlanesSkippable = !mPlanes.empty() && mPlanarStart < mCasterIndexCount;
    {
        // Orient each plane towards the receivers; a plane with receivers on both sides is never
        // left out.
        const float eps = 1e-4f * glm::length(mSceneMax - mSceneMin);
        for (glm::vec4& plane : mPlanes) {
            float lo = 1e30f, hi = -1e30f;
            for (size_t i = 0; i < g.sampleCount(); ++i) {
                if (g.A[i] <= 0.f) continue;
                const float d = plane.x * g.P[i * 3] + plane.y * g.P[i * 3 + 1] + plane.z * g.P[i * 3 + 2] - plane.w;
                lo = std::min(lo, d);
                hi = std::max(hi, d);
            }
            if (hi <= eps && lo < -eps) plane = -plane;
            else if (lo < -eps) mPlanesSkippable = false;
        }
    }
    mCasterVao = positionVao(mCasterVbo, mCasterIbo);
    GLuint vao = 0;
    glCreateVertexArrays(1, &vao);
    mEmptyVao = gl::VertexArray(vao);

    mLightUbo = gl::makeBuffer(nullptr, sizeof(engine::LightBlock), GL_DYNAMIC_STORAGE_BIT);
    mViewUbo = gl::makeBuffer(nullptr, sizeof(engine::ViewBlock), GL_DYNAMIC_STORAGE_BIT);

    struct P {
        gl::Program* out;
        const char* vert;
        const char* frag;
    } programs[] = {{&mShadowProgram, "shadow_depth.vert", "shadow_depth.frag"},
                    {&mAddProgram, "common_fullscreen.vert", "composite_add.frag"},
                    {&mEmissionProgram, "common_fullscreen.vert", "composite_emission.frag"},
                    {&mTonemapProgram, "common_fullscreen.vert", "composite_tonemap.frag"},
                    {&mResolveProgram, "common_fullscreen.vert", "composite_resolve.frag"}};
    for (P& p : programs) {
        auto r = program(p.vert, p.frag);
        if (!r) return r.error();
        *p.out = std::move(r.value());
    }

    {
        // The deform and tessellation programs are variants per number of segments (renderShadow).
        mCasterVertexCount = GLuint(casters.positions.size());
        mDeformed = gl::makeBuffer(nullptr, std::max<size_t>(casters.positions.size(), 1) * 2 * sizeof(glm::vec4));
        mDeformedTexture = gl::makeBufferTexture(GL_RGBA32F, mDeformed);
        mCasterIndexTexture = gl::makeBufferTexture(GL_R32UI, mCasterIbo);
        auto classify = gl::buildProgram({{GL_COMPUTE_SHADER, "bendy_classify.comp", shaders::serverShader("bendy_classify.comp")}});
        if (!classify) return classify.error();
        mBendyClassifyProgram = std::move(classify.value());
        auto flat = gl::buildProgram({{GL_VERTEX_SHADER, "shadow_bendy_flat.vert", shaders::serverShader("shadow_bendy_flat.vert")},
                                      {GL_FRAGMENT_SHADER, "shadow_depth.frag", shaders::serverShader("shadow_depth.frag")}});
        if (!flat) return flat.error();
        mBendyFlatProgram = std::move(flat.value());
        const size_t indexBytes = std::max<size_t>(casters.indices.size(), 3) * sizeof(uint32_t);
        mFlatIndices = gl::makeBuffer(nullptr, indexBytes);
        mTessIndices = gl::makeBuffer(nullptr, indexBytes);
        mIndirect = gl::makeBuffer(nullptr, sizeof(engine::BendyDrawCommands), GL_DYNAMIC_STORAGE_BIT);
        GLuint v = 0;
        glCreateVertexArrays(1, &v);
        mFlatVao = gl::VertexArray(v); // positions come from the deformed buffer by index
        glVertexArrayElementBuffer(v, mFlatIndices.id());
        mTessVao = positionVao(mCasterVbo, mTessIndices);
    }

    mAccum = gl::makeTexture2D(GL_RGBA32F, mWidth, mHeight);
    // sRGB-encoded: the GL applies the sRGB transfer function as it stores the view transform's
    // linear output (GL_FRAMEBUFFER_SRGB), cheaper than the shader doing it.
    mLdr = gl::makeTexture2D(GL_SRGB8_ALPHA8, mWidth, mHeight);
    mStatic = gl::makeTexture2D(GL_RGBA32F, mWidth, mHeight);
    for (auto [fb, texture, what] : {std::tuple{&mStaticFb, &mStatic, "static sum"}, std::tuple{&mAccumFb, &mAccum, "accumulation"},
                                      std::tuple{&mLdrFb, &mLdr, "8-bit output"}}) {
        auto made = gl::makeFramebuffer(texture->id(), 0, what);
        if (!made) return made.error();
        *fb = std::move(made.value());
    }
    return mContext->check("engine initialisation");
}

glm::mat4 GlEngine::lightViewProj(const Light& l) const {
    const glm::vec3 axis = glm::normalize(toGlm(l.direction));
    glm::vec3 up(0, 1, 0);
    if (std::abs(glm::dot(up, axis)) > 0.99f) up = glm::vec3(1, 0, 0);
    if (l.type == LightType::Directional) {
        // An orthographic frustum fitted to what the camera sees (the receivers' bounds) across
        // the light, and stretched towards the light over the whole scene so that every caster
        // that can shadow a receiver is inside.
        const glm::vec3 centre = 0.5f * (mSceneMin + mSceneMax);
        const float radius = 0.5f * glm::length(mSceneMax - mSceneMin) + 1e-3f;
        const glm::mat4 view = glm::lookAt(centre - axis * (2.f * radius), centre, up);
        glm::vec3 lo(1e30f), hi(-1e30f);
        for (int i = 0; i < 8; ++i) {
            const glm::vec3 c((i & 1) ? mReceiverMax.x : mReceiverMin.x, (i & 2) ? mReceiverMax.y : mReceiverMin.y,
                              (i & 4) ? mReceiverMax.z : mReceiverMin.z);
            const glm::vec3 v = glm::vec3(view * glm::vec4(c, 1.f));
            lo = glm::min(lo, v);
            hi = glm::max(hi, v);
        }
        return glm::ortho(lo.x, hi.x, lo.y, hi.y, 1e-3f * radius, 4.f * radius) * view;
    }
    const glm::vec3 pos = toGlm(l.position);
    const glm::mat4 view = glm::lookAt(pos, pos + axis, up);
    // Near/far from the scene's bounds seen from the light: tight planes keep depth precision.
    float farthest = 0.f;
    for (int i = 0; i < 8; ++i) {
        glm::vec3 c((i & 1) ? mSceneMax.x : mSceneMin.x, (i & 2) ? mSceneMax.y : mSceneMin.y,
                    (i & 4) ? mSceneMax.z : mSceneMin.z);
        farthest = std::max(farthest, glm::length(c - pos));
    }
    if (l.type == LightType::Bendy && !l.controlPoints.empty()) {
        // Deformed geometry lies at arc-length distances: up to the chain's length plus whatever
        // the straight extension reaches (at most the scene's extent past the chain's end).
        const auto ch = chainFromLight<float>(l);
        farthest = std::max(farthest, ch.arcStart[ch.segments] + glm::length(mSceneMax - mSceneMin));
    }
    const float zfar = std::max(farthest * 1.01f, 1e-3f);
    const float znear = std::max(zfar * 1e-4f, 1e-5f);
    // The frustum's half-angle must contain the cone's; a square map circumscribes the circle.
    const float fovy = 2.f * glm::radians(shadowHalfAngleDeg(l));
    return glm::perspective(fovy, 1.f, znear, zfar) * view;
}

void GlEngine::uploadBendy(LightCache& c) {
    c.chain = chainFromLight<float>(c.params);
    c.bendy = engine::toBendyBlock(c.chain, c.params.exactDirection);
    if (!c.bendyUbo) c.bendyUbo = gl::makeBuffer(nullptr, sizeof c.bendy, GL_DYNAMIC_STORAGE_BIT);
    glNamedBufferSubData(c.bendyUbo.id(), 0, sizeof c.bendy, &c.bendy);
    glBindBufferBase(GL_UNIFORM_BUFFER, engine::UBO_BENDY, c.bendyUbo.id());
}

// The side of the shadow map a light gets now: its own, or a quarter of it (at least 256) while a
// control is being dragged (progressive refinement, DESIGN section 6).
int shadowSizeFor(const Light& l, bool preview) {
    return preview ? std::min(l.shadowMapSize, std::max(256, l.shadowMapSize / 4)) : l.shadowMapSize;
}

Status GlEngine::renderShadow(LightCache& c) {
    const Light& l = c.params;
    c.previewShadow = mPreview && shadowSizeFor(l, true) != l.shadowMapSize;
    if (l.type == LightType::Point) return renderCubeShadow(c);
    const int size = shadowSizeFor(l, mPreview);
    if (!c.shadowMap || c.shadowIsCube || c.shadowSize != size) {
        c.shadowIsCube = false;
        c.shadowSize = size;
        c.shadowMap = gl::makeTexture2D(GL_DEPTH_COMPONENT32F, c.shadowSize, c.shadowSize);
        glTextureParameteri(c.shadowMap.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        glTextureParameteri(c.shadowMap.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glTextureParameteri(c.shadowMap.id(), GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
        glTextureParameteri(c.shadowMap.id(), GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
        auto fb = gl::makeFramebuffer(0, c.shadowMap.id(), "shadow map of light '" + l.name + "'");
        if (!fb) return fb.error();
        c.shadowFb = std::move(fb.value());
    }
    c.worldToLightClip = lightViewProj(l);
    engine::LightBlock block{};
    block.worldToLightClip = c.worldToLightClip;
    glNamedBufferSubData(mLightUbo.id(), 0, sizeof block, &block);
    glBindBufferBase(GL_UNIFORM_BUFFER, engine::UBO_LIGHT, mLightUbo.id());

    glBindFramebuffer(GL_FRAMEBUFFER, c.shadowFb.id());
    glViewport(0, 0, c.shadowSize, c.shadowSize);
    const float one = 1.f;
    glClearNamedFramebufferfv(c.shadowFb.id(), GL_DEPTH, 0, &one);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    glDisable(GL_CULL_FACE); // casters are not assumed closed
    glDisable(GL_BLEND);
    // Slope-scaled offset against self-shadowing acne; receivers add a normal offset too.
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1.5f, 2.f);
    glBindVertexArray(mCasterVao.id());
    if (l.type == LightType::Bendy) {
        // Deformed shadow map: casters subdivided and mapped Q -> Q' in the tessellation stages.
        uploadBendy(c);
        const std::string segments = mGeneric ? "" : "#define BENDY_K " + std::to_string(c.bendySegments()) + "\n";
        auto deform = variant({"bendy_deform.comp"}, segments);
        if (!deform) return deform.error();
        auto tess = variant({"shadow_bendy.vert", "shadow_bendy.tesc", "shadow_bendy.tese", "shadow_bendy.frag"}, segments);
        if (!tess) return tess.error();
        // Deform every caster vertex once, then draw patches that reuse it.
        glUseProgram(deform.value());
        glUniform1ui(engine::LOC_DEFORM_VERTEX_COUNT, mCasterVertexCount);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, engine::SSBO_CASTER_POSITIONS, mCasterVbo.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, engine::SSBO_DEFORMED, mDeformed.id());
        glDispatchCompute((mCasterVertexCount + engine::COMPUTE_GROUP_SIZE - 1) / engine::COMPUTE_GROUP_SIZE, 1, 1);
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
        const float fovy = 2.f * glm::radians(shadowHalfAngleDeg(l));
        const float texelPerDistance = 2.f * std::tan(0.5f * fovy) / float(c.shadowSize);
        // Sort the triangles: plain draw where no edge needs subdividing, tessellation elsewhere.
        const auto closed = uint32_t(mClosedIndexCount);
        const engine::BendyDrawCommands commands{{0, 1, 0, 0, 0}, {0, 1, closed, 0, 0}, {0, 1, 0, 0, 0}, {0, 1, closed, 0, 0}};
        glNamedBufferSubData(mIndirect.id(), 0, sizeof commands, &commands);
        glUseProgram(mBendyClassifyProgram.id());
        c.casterIndexCount = casterIndices(c);
        const GLuint triangles = GLuint(c.casterIndexCount / 3);
        glUniform1ui(engine::LOC_CLASSIFY_TRIANGLE_COUNT, triangles);
        glUniform1f(engine::LOC_CLASSIFY_MAX_LEVEL, float(mSubdivisionLimit));
        glUniform1f(engine::LOC_CLASSIFY_TEXEL_PER_DISTANCE, texelPerDistance);
        glUniform1ui(engine::LOC_CLASSIFY_CLOSED_TRIANGLES, closed / 3);
        glBindTextureUnit(engine::TEX_DEFORMED, mDeformedTexture.id());
        glBindTextureUnit(engine::TEX_CASTER_INDICES, mCasterIndexTexture.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, engine::SSBO_FLAT_INDICES, mFlatIndices.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, engine::SSBO_TESS_INDICES, mTessIndices.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, engine::SSBO_DRAW_COMMANDS, mIndirect.id());
        glDispatchCompute((triangles + engine::COMPUTE_GROUP_SIZE - 1) / engine::COMPUTE_GROUP_SIZE, 1, 1);
        glMemoryBarrier(GL_COMMAND_BARRIER_BIT | GL_ELEMENT_ARRAY_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
        glBindBuffer(GL_DRAW_INDIRECT_BUFFER, mIndirect.id());
        glUseProgram(mBendyFlatProgram.id());
        glBindVertexArray(mFlatVao.id());
        // Closed meshes front-face culled, as drawCasters (the deformation keeps the winding).
        glEnable(GL_CULL_FACE);
        glCullFace(GL_FRONT);
        glDrawElementsIndirect(GL_TRIANGLES, GL_UNSIGNED_INT, reinterpret_cast<const void*>(offsetof(engine::BendyDrawCommands, plainClosed)));
        glDisable(GL_CULL_FACE);
        glDrawElementsIndirect(GL_TRIANGLES, GL_UNSIGNED_INT, reinterpret_cast<const void*>(offsetof(engine::BendyDrawCommands, plainOpen)));
        glUseProgram(tess.value());
        glBindVertexArray(mTessVao.id());
        glUniform1f(engine::LOC_TESS_MAX_LEVEL, float(mSubdivisionLimit));
        glUniform1f(engine::LOC_TESS_TEXEL_PER_DISTANCE, texelPerDistance);
        glPatchParameteri(GL_PATCH_VERTICES, 3);
        glEnable(GL_CULL_FACE);
        glCullFace(GL_FRONT);
        glDrawElementsIndirect(GL_PATCHES, GL_UNSIGNED_INT, reinterpret_cast<const void*>(offsetof(engine::BendyDrawCommands, tessClosed)));
        glDisable(GL_CULL_FACE);
        glDrawElementsIndirect(GL_PATCHES, GL_UNSIGNED_INT, reinterpret_cast<const void*>(offsetof(engine::BendyDrawCommands, tessOpen)));
        glBindBuffer(GL_DRAW_INDIRECT_BUFFER, 0);
        c.subdivisionLimit = mSubdivisionLimit;
    } else {
        glUseProgram(mShadowProgram.id());
        c.casterIndexCount = casterIndices(c);
        drawCasters(c.casterIndexCount, c.worldToLightClip);
    }
    glDisable(GL_POLYGON_OFFSET_FILL);
    glDisable(GL_DEPTH_TEST);
    c.hasShadow = true;
    return okStatus();
}

// How many caster indices a light's shadow map needs: all, or all but the open planar meshes
// when the light is on the receivers' side of every one of them. Such a plane cannot occlude
// anything then: a spot's, point light's or sun's rays from a receiver to the light stay on that
// side (half-spaces are convex); a BendyLight's light travels along its flow lines, which must
// not reach the plane (lightmath::flowLinesMissPlane: tubes clear of it, or descending towards it).
GLsizei GlEngine::casterIndices(const LightCache& c) const {
    if (!mPlanesSkippable) return mCasterIndexCount;
    const Light& l = c.params;
    const float eps = 1e-4f * glm::length(mSceneMax - mSceneMin);
    const glm::vec3 pos = toGlm(l.position), axis = glm::normalize(toGlm(l.direction));
    for (const glm::vec4& plane : mPlanes) {
        const glm::vec3 n(plane);
        auto dist = [&](const glm::vec3& p) { return glm::dot(n, p) - plane.w; };
        bool clear = false;
        if (l.type == LightType::Directional) {
            clear = glm::dot(n, -axis) > 1e-6f;
        } else if (l.type == LightType::Bendy) {
            // c.chain: uploaded by renderShadow before this is asked.
            clear = lightmath::flowLinesMissPlane(c.chain, n, plane.w, eps);
        } else {
            clear = dist(pos) > eps;
        }
        if (!clear) return mCasterIndexCount;
    }
    return mPlanarStart;
}

// The undeformed casters into the bound depth target: closed meshes with the faces towards the
// light culled (their far side casts the same shadow on everything else and on their own unlit
// side; llvmpipe rasterises about half as much), the rest two-sided, up to index `count`. Meshes
// whose box lies wholly outside one side of the frustum (left, right, bottom or top; near and far
// are left alone) are skipped: they cannot cover a texel, and llvmpipe would still transform and
// clip every one of their triangles (a point light's cube face sees about a sixth of the scene).
void GlEngine::drawCasters(GLsizei count, const glm::mat4& worldToClip) {
    auto outside = [&](const ShadowGeometry::Part& part) {
        if (!std::isfinite(part.min.x)) return false;
        // A bit per clip-space side plane (w + x, w - x, w + y, w - y >= 0) that every corner
        // of the box is outside of.
        unsigned allOut = 15u;
        for (int k = 0; k < 8 && allOut; ++k) {
            const glm::vec3 corner((k & 1) ? part.max.x : part.min.x, (k & 2) ? part.max.y : part.min.y,
                                   (k & 4) ? part.max.z : part.min.z);
            const glm::vec4 clip = worldToClip * glm::vec4(corner, 1.f);
            const unsigned out = (clip.w + clip.x < 0.f ? 1u : 0u) | (clip.w - clip.x < 0.f ? 2u : 0u) |
                                 (clip.w + clip.y < 0.f ? 4u : 0u) | (clip.w - clip.y < 0.f ? 8u : 0u);
            allOut &= out;
        }
        return allOut != 0u;
    };
    // Runs of consecutive drawn meshes become one draw; the closed ones with front faces culled.
    GLsizei runStart = 0, runEnd = 0;
    bool runClosed = false;
    auto flush = [&]() {
        if (runEnd <= runStart) return;
        if (runClosed) {
            glEnable(GL_CULL_FACE);
            glCullFace(GL_FRONT);
        }
        glDrawElements(GL_TRIANGLES, runEnd - runStart, GL_UNSIGNED_INT, reinterpret_cast<const void*>(size_t(runStart) * sizeof(uint32_t)));
        if (runClosed) glDisable(GL_CULL_FACE);
        runStart = runEnd;
    };
    for (const ShadowGeometry::Part& part : mParts) {
        const auto first = GLsizei(part.firstIndex);
        const GLsizei end = std::min(GLsizei(part.firstIndex + part.indexCount), count);
        if (end <= first || outside(part)) continue;
        // A range may straddle the closed/open boundary only when the parts are "everything".
        for (GLsizei a = first; a < end;) {
            const bool closed = a < mClosedIndexCount;
            const GLsizei b = closed ? std::min(end, mClosedIndexCount) : end;
            if (a != runEnd || closed != runClosed) {
                flush();
                runStart = a;
                runClosed = closed;
            }
            runEnd = b;
            a = b;
        }
    }
    flush();
}

Status GlEngine::renderCubeShadow(LightCache& c) {
    const Light& l = c.params;
    const int size = shadowSizeFor(l, mPreview);
    if (!c.shadowMap || !c.shadowIsCube || c.shadowSize != size) {
        c.shadowIsCube = true;
        c.shadowSize = size;
        GLuint id = 0;
        glCreateTextures(GL_TEXTURE_CUBE_MAP, 1, &id);
        c.shadowMap = gl::Texture(id);
        glTextureStorage2D(id, 1, GL_DEPTH_COMPONENT32F, size, size);
        glTextureParameteri(id, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        glTextureParameteri(id, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glTextureParameteri(id, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTextureParameteri(id, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        glTextureParameteri(id, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
        glTextureParameteri(id, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
        GLuint fb = 0;
        glCreateFramebuffers(1, &fb);
        c.shadowFb = gl::Framebuffer(fb);
        glNamedFramebufferDrawBuffer(fb, GL_NONE);
    }
    // Filtering across face edges (the PCF taps of a direction near an edge reach the next face).
    glEnable(GL_TEXTURE_CUBE_MAP_SEAMLESS);
    const glm::vec3 pos = toGlm(l.position);
    float farthest = 0.f;
    for (int i = 0; i < 8; ++i) {
        glm::vec3 corner((i & 1) ? mSceneMax.x : mSceneMin.x, (i & 2) ? mSceneMax.y : mSceneMin.y,
                         (i & 4) ? mSceneMax.z : mSceneMin.z);
        farthest = std::max(farthest, glm::length(corner - pos));
    }
    const float zfar = std::max(farthest * 1.01f, 1e-3f);
    const float znear = std::max(zfar * 1e-4f, 1e-5f);
    c.cubeNearFar = {znear, zfar};
    const glm::mat4 proj = glm::perspective(glm::radians(90.f), 1.f, znear, zfar);
    // GL's cube-map face orientations (GL 4.5 section 8.13, table 8.19): face i is looked up for
    // directions whose major axis is `target`, with s and t along the faces' -z/x/.. axes, which
    // is what a camera with these up vectors renders.
    const glm::vec3 targets[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    const glm::vec3 ups[6] = {{0, -1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}, {0, -1, 0}, {0, -1, 0}};
    glBindFramebuffer(GL_FRAMEBUFFER, c.shadowFb.id());
    glViewport(0, 0, size, size);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    glDisable(GL_CULL_FACE);
    glDisable(GL_BLEND);
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1.5f, 2.f);
    glUseProgram(mShadowProgram.id());
    glBindVertexArray(mCasterVao.id());
    const float one = 1.f;
    c.casterIndexCount = casterIndices(c);
    for (int face = 0; face < 6; ++face) {
        glNamedFramebufferTextureLayer(c.shadowFb.id(), GL_DEPTH_ATTACHMENT, c.shadowMap.id(), 0, face);
        if (face == 0) {
            if (auto s = gl::checkFramebuffer(c.shadowFb.id(), ("cube shadow map of light '" + l.name + "'").c_str()); !s) return s;
        }
        glClearNamedFramebufferfv(c.shadowFb.id(), GL_DEPTH, 0, &one);
        engine::LightBlock block{};
        block.worldToLightClip = proj * glm::lookAt(pos, pos + targets[face], ups[face]);
        glNamedBufferSubData(mLightUbo.id(), 0, sizeof block, &block);
        glBindBufferBase(GL_UNIFORM_BUFFER, engine::UBO_LIGHT, mLightUbo.id());
        drawCasters(c.casterIndexCount, block.worldToLightClip);
    }
    glDisable(GL_POLYGON_OFFSET_FILL);
    glDisable(GL_DEPTH_TEST);
    c.hasShadow = true;
    return okStatus();
}

Result<GLuint> GlEngine::cookieTexture(const Light& l) {
    auto it = mCookies.find(l.cookie);
    if (it != mCookies.end()) return it->second.id();
    const std::string path = (std::filesystem::path(mAssetDir) / l.cookie).string();
    auto img = readLinearImage(path);
    if (!img) {
        return makeError(img.error().code, "light '" + l.name + "': cookie '" + l.cookie + "': " + img.error().message);
    }
    const int levels = 1 + int(std::floor(std::log2(double(std::max(img->width, img->height)))));
    GLuint id = 0;
    glCreateTextures(GL_TEXTURE_2D, 1, &id);
    gl::Texture t(id);
    glTextureStorage2D(id, levels, GL_RGBA16F, img->width, img->height);
    // Row 0 of the image (its top) goes to t = 1, the light's up (relight_spot.frag).
    std::vector<float> flipped(img->rgba.size());
    const size_t row = size_t(img->width) * 4;
    for (int y = 0; y < img->height; ++y)
        std::copy_n(img->rgba.begin() + ptrdiff_t(size_t(y) * row), row, flipped.begin() + ptrdiff_t(size_t(img->height - 1 - y) * row));
    glTextureSubImage2D(id, 0, 0, 0, img->width, img->height, GL_RGBA, GL_FLOAT, flipped.data());
    glGenerateTextureMipmap(id);
    glTextureParameteri(id, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTextureParameteri(id, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(id, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(id, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    return mCookies.emplace(l.cookie, std::move(t)).first->second.id();
}

Status GlEngine::shade(LightCache& c, int output) {
    const Light& l = c.params;
    if (!c.contribution) {
        c.contribution = gl::makeTexture2D(GL_RGBA16F, mWidth, mHeight);
        if (!mMaskDepth) mMaskDepth = gl::makeTexture2D(GL_DEPTH_COMPONENT32F, mWidth, mHeight);
        auto fb = gl::makeFramebuffer(c.contribution.id(), mMaskDepth.id(), "contribution of light '" + l.name + "'");
        if (!fb) return fb.error();
        c.contributionFb = std::move(fb.value());
    }
    engine::LightBlock block{};
    block.worldToLightClip = c.worldToLightClip;
    // w = 0 marks a directional light: parallel rays, no distance or cone falloff.
    block.lightPosition = glm::vec4(toGlm(l.position), l.type == LightType::Directional ? 0.f
                                                       : l.type == LightType::Point     ? 2.f
                                                                                        : 1.f);
    block.lightAxis = glm::vec4(glm::normalize(toGlm(l.direction)), 0.f);
    block.lightRadiance = glm::vec4(toGlm(l.color) * l.intensityCd, 0.f);
    const float outer = glm::radians(l.coneAngleDeg);
    const float inner = glm::radians(std::max(l.coneAngleDeg - l.penumbraDeg, 0.f));
    const bool shadowed = l.shadow;
    // Normal offset: `shadowBias` shadow-map texels, whose world size grows linearly with distance
    // (a cube face spans 90 degrees: 2 / size per unit distance).
    const int mapSize = c.hasShadow ? c.shadowSize : l.shadowMapSize;
    const float fovy = 2.f * glm::radians(l.type == LightType::Point ? 45.f : shadowHalfAngleDeg(l));
    const float texelPerDistance = 2.f * std::tan(0.5f * fovy) / float(std::max(mapSize, 1));
    float normalOffset = l.shadowBias * texelPerDistance;
    if (l.type == LightType::Directional) {
        // Orthographic texels have one world size: the frustum's width over the map's.
        const glm::mat4 m = glm::inverse(c.worldToLightClip);
        const float width = glm::length(glm::vec3(m * glm::vec4(1, 0, 0, 1)) / (m * glm::vec4(1, 0, 0, 1)).w -
                                        glm::vec3(m * glm::vec4(-1, 0, 0, 1)) / (m * glm::vec4(-1, 0, 0, 1)).w);
        normalOffset = l.shadowBias * width / float(std::max(mapSize, 1));
    }
    block.lightCone = glm::vec4(std::cos(outer), std::max(std::cos(inner), std::cos(outer) + 1e-5f),
                                shadowed ? 1.f : 0.f, normalOffset);
    block.lightShadow = glm::vec4(1.f / float(std::max(mapSize, 1)), float(l.shadowFilter), c.shadowIsCube ? 1.f : 0.f, 0.f);
    GLuint cookie = 0;
    {
        // The spot's frame, as its shadow frustum's (lightViewProj): barn doors and cookie.
        const glm::vec3 axis = glm::normalize(toGlm(l.direction));
        glm::vec3 up(0, 1, 0);
        if (std::abs(glm::dot(up, axis)) > 0.99f) up = glm::vec3(1, 0, 0);
        const glm::vec3 right = glm::normalize(glm::cross(axis, up));
        if (l.type == LightType::Spot && !l.cookie.empty()) {
            auto t = cookieTexture(l);
            if (!t) return t.error();
            cookie = t.value();
        }
        glBindTextureUnit(engine::TEX_COOKIE, cookie);
        block.lightRight = glm::vec4(right, cookie ? 1.f : 0.f);
        block.lightUp = glm::vec4(glm::cross(right, axis), std::tan(outer));
        // An open door (90 degrees) must never cut: put it out of atan's reach.
        auto door = [&](int i) { return l.barnDoorsDeg[size_t(i)] >= 90.f ? 10.f : glm::radians(l.barnDoorsDeg[size_t(i)]); };
        block.lightDoors = l.type == LightType::Spot ? glm::vec4(door(0), door(1), door(2), door(3)) : glm::vec4(10.f);
        block.lightCube = glm::vec4(c.cubeNearFar, 0.f, 0.f);
    }
    glNamedBufferSubData(mLightUbo.id(), 0, sizeof block, &block);
    glBindBufferBase(GL_UNIFORM_BUFFER, engine::UBO_LIGHT, mLightUbo.id());

    // Preview frames shade every second pixel into a half-size image (progressive refinement);
    // shadow masks and full frames shade every pixel.
    const int step = mPreview && output == 0 ? 2 : 1;
    // A deep buffer's full frames shade once per sample over the sample textures' layout (the
    // flat shaders, DFB_FLAT_SAMPLES, read the sample at their fragment) and then sum each
    // pixel's samples: no per-pixel loop whose longest pixel every lane of a group waits for.
    const bool perSample = !mFlat && !mGeneric && step == 1;
    GLuint target = c.contributionFb.id();
    if (perSample) {
        if (!mSampleFb) {
            mSampleRadiance = gl::makeTexture2D(GL_RGBA32F, mSampleRow, mSampleRows);
            mSampleDepth = gl::makeTexture2D(GL_DEPTH_COMPONENT32F, mSampleRow, mSampleRows);
            auto fb = gl::makeFramebuffer(mSampleRadiance.id(), mSampleDepth.id(), "per-sample radiance");
            if (!fb) return fb.error();
            mSampleFb = std::move(fb.value());
        }
        target = mSampleFb.id();
    }
    glBindFramebuffer(GL_FRAMEBUFFER, target);
    if (perSample) glViewport(0, 0, mSampleRow, mSampleRows);
    else glViewport(0, 0, (mWidth + step - 1) / step, (mHeight + step - 1) / step);
    glDisable(GL_BLEND);
    glDisable(GL_DEPTH_TEST);
    // Light linking: a bit per object id, lit where set.
    const bool linked = !l.include.empty() || !l.exclude.empty();
    if (l.type == LightType::Bendy) uploadBendy(c);
    const std::string defines = shadeDefines(c, output, cookie != 0, linked) + (perSample ? "#define DFB_FLAT_SAMPLES 1\n" : "");
    auto shader = variant({"common_fullscreen.vert", l.type == LightType::Bendy ? "relight_bendy.frag" : "relight_spot.frag"}, defines);
    if (!shader) return shader.error();
    // A light reaches part of the frame (the surfaces facing it; a spot's cone; a BendyLight's
    // tubes): mark that footprint in the depth buffer first, and the shading pass's early depth
    // test skips the rest (relight_mask.frag).
    const bool footprint = !mGeneric;
    if (footprint) {
        auto mask = variant({"common_fullscreen.vert", "relight_mask.frag"},
                            defines + (l.type == LightType::Bendy ? "#define SHADE_BENDY 1\n" : ""));
        if (!mask) return mask.error();
        const float zero[4] = {0.f, 0.f, 0.f, 0.f}, far = 1.f;
        glClearNamedFramebufferfv(target, GL_COLOR, 0, zero);
        glClearNamedFramebufferfv(target, GL_DEPTH, 0, &far);
        glUseProgram(mask.value());
        glUniform1i(engine::LOC_RELIGHT_PIXEL_STEP, step);
        glBindTextureUnit(engine::TEX_GBUFFER_P, mP.id());
        glBindTextureUnit(engine::TEX_GBUFFER_N, mN.id());
        glBindTextureUnit(engine::TEX_PIXEL_SAMPLES, mPixelSamples.id());
        glBindVertexArray(mEmptyVao.id());
        glEnable(GL_DEPTH_TEST);
        glDepthFunc(GL_ALWAYS);
        glDepthMask(GL_TRUE);
        glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
        glDrawArrays(GL_TRIANGLES, 0, 3);
        glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
        glDepthFunc(GL_EQUAL);
        glDepthMask(GL_FALSE);
    }
    glUseProgram(shader.value());
    glUniform1i(engine::LOC_RELIGHT_OUTPUT, output);
    glUniform1i(engine::LOC_RELIGHT_PIXEL_STEP, step);
    glUniform1i(engine::LOC_RELIGHT_LINKED, linked ? 1 : 0);
    if (linked) {
        std::vector<uint32_t> mask((std::max(mMaxObjectId, 1u) + 32) / 32, l.include.empty() ? ~0u : 0u);
        auto setBit = [&](uint32_t id, bool on) {
            if (id / 32 >= mask.size()) return;
            if (on) mask[id / 32] |= 1u << (id % 32);
            else mask[id / 32] &= ~(1u << (id % 32));
        };
        for (uint32_t id : l.include) setBit(id, true);
        for (uint32_t id : l.exclude) setBit(id, false);
        c.linkMask = gl::makeBuffer(mask.data(), mask.size() * sizeof(uint32_t));
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, engine::SSBO_LINK_MASK, c.linkMask.id());
    } else {
        if (!mNoLink) {
            const uint32_t all = ~0u;
            mNoLink = gl::makeBuffer(&all, sizeof all);
        }
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, engine::SSBO_LINK_MASK, mNoLink.id());
    }
    glBindTextureUnit(engine::TEX_GBUFFER_ID, mIds.id());
    glBindTextureUnit(engine::TEX_GBUFFER_P, mP.id());
    glBindTextureUnit(engine::TEX_GBUFFER_N, mN.id());
    glBindTextureUnit(engine::TEX_GBUFFER_NG, mNg.id());
    glBindTextureUnit(engine::TEX_GBUFFER_ALBEDO, mAlbedo.id());
    glBindTextureUnit(engine::TEX_GBUFFER_BRDF, mBrdf.id());
    glBindTextureUnit(engine::TEX_GBUFFER_SHEEN, mSheen.id());
    glBindTextureUnit(engine::TEX_GBUFFER_COAT, mCoat.id());
    glBindTextureUnit(engine::TEX_PIXEL_SAMPLES, mPixelSamples.id());
    // An unshadowed light still needs a complete texture on the shadow unit: reuse its own or any.
    glBindTextureUnit(engine::TEX_SHADOW_MAP, c.shadowMap && !c.shadowIsCube ? c.shadowMap.id() : 0);
    glBindTextureUnit(engine::TEX_SHADOW_CUBE, c.shadowMap && c.shadowIsCube ? c.shadowMap.id() : 0);
    glBindVertexArray(mEmptyVao.id());
    if (footprint && l.type == LightType::Bendy) {
        // Pixels whose samples lie in at most one segment's round cone (depth 0.25, relight_mask.frag)
        // with the variant that solves one segment; the others (0.75) solve every segment.
        auto single = variant({"common_fullscreen.vert", "relight_bendy.frag"}, defines + "#define BENDY_SINGLE 1\n");
        if (!single) return single.error();
        glDepthRange(0.75, 0.75);
        glDrawArrays(GL_TRIANGLES, 0, 3);
        glUseProgram(single.value());
        glUniform1i(engine::LOC_RELIGHT_OUTPUT, output);
        glUniform1i(engine::LOC_RELIGHT_LINKED, linked ? 1 : 0);
        glUniform1i(engine::LOC_RELIGHT_PIXEL_STEP, step);
        glDepthRange(0.25, 0.25);
        glDrawArrays(GL_TRIANGLES, 0, 3);
        glDepthRange(0.0, 1.0);
    } else {
        glDrawArrays(GL_TRIANGLES, 0, 3);
    }
    glDisable(GL_DEPTH_TEST);
    glDepthMask(GL_TRUE);
    glDepthFunc(GL_LESS);
    if (perSample) {
        glBindFramebuffer(GL_FRAMEBUFFER, c.contributionFb.id());
        glViewport(0, 0, mWidth, mHeight);
        glUseProgram(mResolveProgram.id());
        glBindTextureUnit(engine::TEX_INPUT, mSampleRadiance.id());
        glBindTextureUnit(engine::TEX_PIXEL_SAMPLES, mPixelSamples.id());
        glDrawArrays(GL_TRIANGLES, 0, 3);
    }
    c.hasContribution = true;
    if (output == 0) {
        c.previewShading = step != 1;
        c.shadedRadiance = toGlm(l.color) * l.intensityCd;
        c.scale = glm::vec3(1.f);
        ++c.version;
    }
    return okStatus();
}

// Waits for the GPU to finish what was submitted, at most GPU_TIMEOUT: a hung GPU or a lost
// context becomes an error naming the stage instead of a hang (Context::check reads the reset
// status that robust contexts report).
Status GlEngine::waitGpu(const char* stage) {
    constexpr GLuint64 GPU_TIMEOUT_NS = 20'000'000'000ull;
    GLsync fence = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
    GLenum r = fence ? glClientWaitSync(fence, GL_SYNC_FLUSH_COMMANDS_BIT, GPU_TIMEOUT_NS) : GLenum(GL_WAIT_FAILED);
    if (fence) glDeleteSync(fence);
    Status s = okStatus();
    if (r == GL_TIMEOUT_EXPIRED) {
        s = makeError(ErrorCode::GpuError, std::string("the GPU did not finish the ") + stage +
                                               " within 20 s (hung GPU or lost context); restart the server");
    } else if (r == GL_WAIT_FAILED) {
        s = makeError(ErrorCode::GpuError, std::string("waiting for the GPU failed after the ") + stage);
    }
    if (s) s = mContext->check(stage);
    if (!s) mFailure = s.error();
    return s;
}

// Shadow maps, shading and the sum of the contributions into mAccum. With `fused`, the usual case
// of an edit (the static sum valid, one hot light) leaves the sum to the caller's view-transform
// pass instead (*fused = true): one full-frame pass instead of three.
Status GlEngine::renderAccumulation(const Rig& rig, FrameStats& st, bool* fused) {
    if (mFailure) return *mFailure;
    if (auto s = mContext->makeCurrent(); !s) return s;
    engine::ViewBlock view{};
    view.cameraPosition = glm::vec4(mCameraPosition, mOrthographic ? 1.f : 0.f);
    view.cameraForward = glm::vec4(mCameraForward, 0.f);
    view.exposure = glm::vec4(std::exp2(rig.exposureStops), rig.viewTransform == ViewTransform::Filmic ? 1.f : 0.f, 0, 0);
    view.sampleLayout = glm::ivec4(mSampleRow, std::countr_zero(unsigned(mSampleRow)), 0, 0);
    glNamedBufferSubData(mViewUbo.id(), 0, sizeof view, &view);
    glBindBufferBase(GL_UNIFORM_BUFFER, engine::UBO_VIEW, mViewUbo.id());

    // Forget lights that left the rig (their GL objects are released here).
    for (auto it = mLights.begin(); it != mLights.end();) {
        it = rig.find(it->first) ? std::next(it) : mLights.erase(it);
    }

    auto t = Clock::now();
    for (const Light& l : rig.lights) {
        if (!l.enabled) continue;
        LightCache& c = mLights[l.name];
        const bool shadowValid = c.hasShadow && sameShadowInputs(c.params, l) && (mPreview || !c.previewShadow) &&
                                 (l.type != LightType::Bendy || c.subdivisionLimit == mSubdivisionLimit);
        if (l.shadow && !shadowValid) {
            c.params = l;
            c.hasContribution = false;
            if (auto s = renderShadow(c); !s) return s;
            ++st.shadowMapsRendered;
            st.shadowCasterTriangles += c.casterIndexCount / 3;
        } else if (!l.shadow && !sameShadowInputs(c.params, l)) {
            c.worldToLightClip = lightViewProj(l);
            c.hasShadow = false;
            c.hasContribution = false;
        }
    }
    if (auto s = waitGpu("shadow maps"); !s) return s;
    st.shadowMs = msSince(t);

    t = Clock::now();
    for (const Light& l : rig.lights) {
        if (!l.enabled) continue;
        LightCache& c = mLights[l.name];
        if (c.hasContribution && sameShadingInputs(c.params, l) && (mPreview || !c.previewShading)) {
            // Colour or intensity only: rescale, unless a channel shaded at zero must now light.
            const glm::vec3 radiance = toGlm(l.color) * l.intensityCd;
            bool rescalable = true;
            glm::vec3 scale(0.f);
            for (int k = 0; k < 3; ++k) {
                if (c.shadedRadiance[k] > 0.f) scale[k] = radiance[k] / c.shadedRadiance[k];
                else rescalable = rescalable && radiance[k] <= 0.f;
            }
            if (rescalable) {
                if (scale != c.scale) {
                    c.scale = scale;
                    ++c.version;
                }
                c.params = l;
                continue;
            }
        }
        c.params = l;
        if (auto s = shade(c); !s) return s;
        ++st.lightsShaded;
    }
    if (auto s = waitGpu("shading"); !s) return s;
    st.shadeMs = msSince(t);

    t = Clock::now();
    std::string structure;
    std::vector<std::string> changed;
    for (const Light& l : rig.lights) {
        if (!l.enabled) continue;
        structure += l.name + '\n';
        const LightCache& c = mLights[l.name];
        if (c.version != c.compositedVersion) changed.push_back(l.name);
    }
    glBindVertexArray(mEmptyVao.id());
    glViewport(0, 0, mWidth, mHeight);
    auto addLight = [&](const std::string& name) {
        const LightCache& c = mLights[name];
        glUniform3f(engine::LOC_COMPOSITE_SCALE, c.scale.x, c.scale.y, c.scale.z);
        glUniform1i(engine::LOC_COMPOSITE_PIXEL_STEP, c.previewShading ? 2 : 1);
        glBindTextureUnit(engine::TEX_INPUT, c.contribution.id());
        glDrawArrays(GL_TRIANGLES, 0, 3);
    };
    auto emission = [&]() {
        glDisable(GL_BLEND);
        glUseProgram(mEmissionProgram.id());
        glBindTextureUnit(engine::TEX_GBUFFER_EMISSION, mEmission.id());
        glBindTextureUnit(engine::TEX_GBUFFER_P, mP.id());
        glBindTextureUnit(engine::TEX_PIXEL_SAMPLES, mPixelSamples.id());
        glDrawArrays(GL_TRIANGLES, 0, 3);
    };
    const bool sameStructure = structure == mStructure;
    const bool onlyHotChanged = sameStructure && mStaticValid &&
                                (changed.empty() || (changed.size() == 1 && changed[0] == mHot));
    if (!onlyHotChanged && sameStructure && changed.size() == 1) {
        // A new light is being edited: sum every other one once into the static image.
        mHot = changed[0];
        glBindFramebuffer(GL_FRAMEBUFFER, mStaticFb.id());
        emission();
        glEnable(GL_BLEND);
        glBlendFunc(GL_ONE, GL_ONE);
        glUseProgram(mAddProgram.id());
        for (const Light& l : rig.lights)
            if (l.enabled && l.name != mHot) addLight(l.name);
        mStaticValid = true;
    } else if (!onlyHotChanged) {
        mStaticValid = false;
        mHot.clear();
    }
    mStructure = structure;
    if (fused) *fused = mStaticValid;
    glBindFramebuffer(GL_FRAMEBUFFER, mAccumFb.id());
    if (fused && *fused) {
        // render() adds the hot light to the static sum in its view-transform pass.
    } else if (mStaticValid) {
        // Frame = static + the hot light: two draws whatever the number of lights.
        glDisable(GL_BLEND);
        glUseProgram(mAddProgram.id());
        glUniform3f(engine::LOC_COMPOSITE_SCALE, 1.f, 1.f, 1.f);
        glUniform1i(engine::LOC_COMPOSITE_PIXEL_STEP, 1);
        glBindTextureUnit(engine::TEX_INPUT, mStatic.id());
        glDrawArrays(GL_TRIANGLES, 0, 3);
        glEnable(GL_BLEND);
        glBlendFunc(GL_ONE, GL_ONE);
        if (rig.find(mHot)) addLight(mHot);
    } else {
        emission();
        glEnable(GL_BLEND);
        glBlendFunc(GL_ONE, GL_ONE);
        glUseProgram(mAddProgram.id());
        for (const Light& l : rig.lights)
            if (l.enabled) addLight(l.name);
    }
    glDisable(GL_BLEND);
    for (const Light& l : rig.lights) {
        if (l.enabled) mLights[l.name].compositedVersion = mLights[l.name].version;
    }
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
    glBindFramebuffer(GL_FRAMEBUFFER, mLdrFb.id());
    glViewport(0, 0, mWidth, mHeight);
    glDisable(GL_BLEND);
    glBindVertexArray(mEmptyVao.id());
    if (fused) {
        // Static sum + the hot light, exposure and view transform in one pass.
        auto program = variant({"common_fullscreen.vert", "composite_tonemap.frag"}, "#define TONEMAP_ADD_HOT 1\n");
        if (!program) return program.error();
        glUseProgram(program.value());
        glBindTextureUnit(engine::TEX_INPUT, mStatic.id());
        const auto hot = mLights.find(mHot);
        const Light* hotLight = rig.find(mHot);
        if (hot != mLights.end() && hotLight && hotLight->enabled && hot->second.contribution) {
            glUniform3f(engine::LOC_COMPOSITE_SCALE, hot->second.scale.x, hot->second.scale.y, hot->second.scale.z);
            glUniform1i(engine::LOC_COMPOSITE_PIXEL_STEP, hot->second.previewShading ? 2 : 1);
            glBindTextureUnit(engine::TEX_INPUT_HOT, hot->second.contribution.id());
        } else {
            glUniform3f(engine::LOC_COMPOSITE_SCALE, 0.f, 0.f, 0.f);
            glUniform1i(engine::LOC_COMPOSITE_PIXEL_STEP, 1);
            glBindTextureUnit(engine::TEX_INPUT_HOT, mStatic.id());
        }
    } else {
        glUseProgram(mTonemapProgram.id());
        glBindTextureUnit(engine::TEX_INPUT, mAccum.id());
    }
    glEnable(GL_FRAMEBUFFER_SRGB);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glDisable(GL_FRAMEBUFFER_SRGB); // and read back the stored (encoded) bytes unchanged
    if (auto s = waitGpu("view transform"); !s) return s.error();
    st.compositeMs += msSince(t); // the view transform belongs to the composite stage

    t = Clock::now();
    Image8 img;
    img.width = mWidth;
    img.height = mHeight;
    const size_t bytes = size_t(mWidth) * size_t(mHeight) * 4;
    img.rgba.resize(bytes);
    if (!mReadback) {
        const GLbitfield map = GL_MAP_READ_BIT | GL_MAP_PERSISTENT_BIT | GL_MAP_COHERENT_BIT;
        mReadback = gl::makeBuffer(nullptr, bytes, map | GL_CLIENT_STORAGE_BIT);
        mReadbackPixels = static_cast<const uint8_t*>(glMapNamedBufferRange(mReadback.id(), 0, GLsizeiptr(bytes), map));
        if (!mReadbackPixels) return makeError(ErrorCode::GpuError, "cannot map the frame's read-back buffer");
    }
    glBindFramebuffer(GL_READ_FRAMEBUFFER, mLdrFb.id());
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glBindBuffer(GL_PIXEL_PACK_BUFFER, mReadback.id());
    glReadPixels(0, 0, mWidth, mHeight, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
    glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    if (auto s = waitGpu("read-back"); !s) return s.error();
    // Several threads copy: one memcpy of a 1080p frame takes longer than its transfer.
    const size_t parts = std::clamp<size_t>(bytes / (1u << 20), 1, 8);
    const size_t chunk = (bytes + parts - 1) / parts;
    WorkerPool::shared().run(int(parts), [&](int i) {
        const size_t at = std::min(bytes, size_t(i) * chunk);
        std::memcpy(img.rgba.data() + at, mReadbackPixels + at, std::min(chunk, bytes - at));
    });
    st.readbackMs = msSince(t);
    if (auto s = mContext->check("relight frame"); !s) return s.error();
    return img;
}

// Reads an image-sized float texture back, times `scale` per channel.
Result<ImageF> GlEngine::readFloat(GLuint texture, const char* what, glm::vec3 scale) {
    ImageF img;
    img.width = mWidth;
    img.height = mHeight;
    img.rgba.resize(size_t(mWidth) * size_t(mHeight) * 4);
    glGetTextureImage(texture, 0, GL_RGBA, GL_FLOAT, GLsizei(img.rgba.size() * sizeof(float)), img.rgba.data());
    if (scale != glm::vec3(1.f)) {
        for (size_t i = 0; i < img.rgba.size(); i += 4)
            for (int k = 0; k < 3; ++k) img.rgba[i + size_t(k)] *= scale[k];
    }
    if (auto s = mContext->check(what); !s) return s.error();
    return img;
}

// Outputs that read single lights' contributions are always full quality, even mid-drag.
struct FullQuality {
    bool& preview;
    bool saved;
    explicit FullQuality(bool& p) : preview(p), saved(p) { preview = false; }
    ~FullQuality() { preview = saved; }
    FullQuality(const FullQuality&) = delete;
    FullQuality& operator=(const FullQuality&) = delete;
};

Result<ImageF> GlEngine::renderLightLinear(const Rig& rig, const std::string& lightName) {
    const Light* l = rig.find(lightName);
    if (!l) return makeError(ErrorCode::MissingData, "no light named '" + lightName + "'");
    FullQuality full(mPreview);
    FrameStats st;
    if (auto s = renderAccumulation(rig, st); !s) return s.error();
    if (!l->enabled) {
        ImageF black;
        black.width = mWidth;
        black.height = mHeight;
        black.rgba.assign(size_t(mWidth) * size_t(mHeight) * 4, 0.f);
        return black;
    }
    const LightCache& c = mLights[lightName];
    return readFloat(c.contribution.id(), "light alone", c.scale);
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
    if (auto s = shade(c, 1); !s) return s.error();
    c.hasContribution = false; // the next frame re-shades it (and rebuilds the sums that hold it)
    ++c.version;
    return readFloat(c.contribution.id(), "shadow mask");
}

Result<std::vector<NamedImageF>> GlEngine::renderLayers(const Rig& rig) {
    FullQuality full(mPreview);
    FrameStats st;
    if (auto s = renderAccumulation(rig, st); !s) return s.error();
    std::vector<NamedImageF> layers;
    auto beauty = readFloat(mAccum.id(), "beauty layer");
    if (!beauty) return beauty.error();
    for (size_t i = 3; i < beauty->rgba.size(); i += 4) beauty->rgba[i] = 1.f;
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

Result<ImageF> GlEngine::renderLinear(const Rig& rig) {
    FrameStats st;
    if (auto s = renderAccumulation(rig, st); !s) return s.error();
    return readFloat(mAccum.id(), "relight frame (linear)");
}

} // namespace

bool isClosedMesh(const std::vector<glm::vec3>& positions, const std::vector<uint32_t>& indices) {
    if (indices.empty() || indices.size() % 3 != 0) return false;
    // Weld by exact position: glTF splits vertices at UV seams and hard edges.
    std::unordered_map<std::string_view, uint32_t> weld;
    std::vector<uint32_t> id(positions.size());
    for (size_t i = 0; i < positions.size(); ++i) {
        const std::string_view key(reinterpret_cast<const char*>(&positions[i]), sizeof(glm::vec3));
        id[i] = weld.try_emplace(key, uint32_t(weld.size())).first->second;
    }
    std::unordered_map<uint64_t, int> edges; // directed edge (a << 32 | b) -> uses
    auto edge = [](uint32_t a, uint32_t b) { return uint64_t(a) << 32 | b; };
    for (size_t t = 0; t < indices.size(); t += 3) {
        uint32_t v[3];
        for (int k = 0; k < 3; ++k) {
            if (indices[t + size_t(k)] >= positions.size()) return false;
            v[k] = id[indices[t + size_t(k)]];
        }
        if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) continue;
        for (int k = 0; k < 3; ++k) ++edges[edge(v[k], v[(k + 1) % 3])];
    }
    if (edges.empty()) return false;
    for (const auto& [e, n] : edges) {
        const auto partner = edges.find(edge(uint32_t(e & 0xffffffffu), uint32_t(e >> 32)));
        if (n != 1 || partner == edges.end() || partner->second != 1) return false;
    }
    return true;
}

std::optional<glm::vec4> meshPlane(const std::vector<glm::vec3>& positions, const std::vector<uint32_t>& indices) {
    if (positions.empty() || indices.size() < 3) return std::nullopt;
    glm::vec3 lo(1e30f), hi(-1e30f);
    for (const glm::vec3& p : positions) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    const float extent = glm::length(hi - lo);
    glm::vec3 n(0.f);
    for (size_t t = 0; t + 2 < indices.size() && glm::length(n) == 0.f; t += 3) {
        if (indices[t] >= positions.size() || indices[t + 1] >= positions.size() || indices[t + 2] >= positions.size()) return std::nullopt;
        const glm::vec3 c = glm::cross(positions[indices[t + 1]] - positions[indices[t]], positions[indices[t + 2]] - positions[indices[t]]);
        if (glm::length(c) > 1e-6f * extent * extent) n = glm::normalize(c);
    }
    if (glm::length(n) == 0.f) return std::nullopt;
    const float d = glm::dot(n, positions[indices[0]]);
    for (const glm::vec3& p : positions)
        if (std::abs(glm::dot(n, p) - d) > 1e-5f * extent) return std::nullopt;
    return glm::vec4(n, d);
}

ShadowGeometry shadowCasters(const Scene& scene) {
    ShadowGeometry g;
    std::vector<const MeshPart*> closed, open, planar;
    std::vector<glm::vec4> planes;
    for (const MeshPart& p : scene.parts) {
        if (isClosedMesh(p.positions, p.indices)) {
            closed.push_back(&p);
        } else if (auto plane = meshPlane(p.positions, p.indices)) {
            planar.push_back(&p);
            planes.push_back(*plane);
        } else {
            open.push_back(&p);
        }
    }
    // Each mesh in runs of CLUSTER triangles (meshes list neighbouring triangles near each other,
    // so a run's box is small): a map skips the runs outside its frustum, not only whole meshes.
    constexpr size_t CLUSTER = 2048;
    auto append = [&g](const MeshPart& p) {
        const auto base = uint32_t(g.positions.size());
        g.positions.insert(g.positions.end(), p.positions.begin(), p.positions.end());
        for (size_t at = 0; at + 3 <= p.indices.size(); at += 3 * CLUSTER) {
            ShadowGeometry::Part part;
            part.firstIndex = g.indices.size();
            part.indexCount = std::min(3 * CLUSTER, p.indices.size() / 3 * 3 - at);
            part.min = glm::vec3(1e30f);
            part.max = glm::vec3(-1e30f);
            for (size_t i = at; i < at + part.indexCount; ++i) {
                if (p.indices[i] < p.positions.size()) { // (a loaded scene's always are)
                    part.min = glm::min(part.min, p.positions[p.indices[i]]);
                    part.max = glm::max(part.max, p.positions[p.indices[i]]);
                }
                g.indices.push_back(base + p.indices[i]);
            }
            g.parts.push_back(part);
        }
    };
    for (const MeshPart* p : closed) append(*p);
    g.closedIndexCount = g.indices.size();
    for (const MeshPart* p : open) append(*p);
    g.planarIndexStart = g.indices.size();
    for (const MeshPart* p : planar) append(*p);
    g.planes = planes;
    return g;
}

Result<std::unique_ptr<Engine>> Engine::create(const DeepBuffer& gbuffer, const ShadowGeometry& casters) {
    auto e = std::make_unique<GlEngine>();
    if (auto s = e->init(gbuffer, casters); !s) return s.error();
    return std::unique_ptr<Engine>(std::move(e));
}

void keepFreedMemoryForFrames() {
    mallopt(M_TRIM_THRESHOLD, 256 << 20); // keep up to 256 MB freed at the heap's top
    mallopt(M_MMAP_THRESHOLD, 32 << 20);  // blocks under 32 MB (frames, bins) from the heap
}

} // namespace dfb
