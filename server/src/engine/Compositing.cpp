#include "Compositing.h"

#include "GpuInterface.h"
#include "WorkerPool.h"

#include <algorithm>
#include <cstring>
#include <tuple>
#include <vector>

namespace dfb::engine {
namespace {

// A contribution's colour x intensity and pixel step (2: shaded at half resolution) for composite_add.frag
// and composite_tonemap.frag's TONEMAP_ADD_HOT.
void setContributionUniforms(const glm::vec3& scale, bool preview) {
    glUniform3f(LOC_COMPOSITE_SCALE, scale.x, scale.y, scale.z);
    glUniform1i(LOC_COMPOSITE_PIXEL_STEP, preview ? 2 : 1);
}

void additive() {
    glEnable(GL_BLEND);
    glBlendFunc(GL_ONE, GL_ONE);
}

} // namespace

// Context::check reads the reset status that robust contexts report.
Status waitForGpu(gl::Context& context, const char* stage) {
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
    if (s) s = context.check(stage);
    return s;
}

Status Compositor::init() {
    struct P {
        GLuint* out;
        const char* frag;
    } programs[] = {{&mAddProgram, "composite_add.frag"}, {&mEmissionProgram, "composite_emission.frag"},
                    {&mTonemapProgram, "composite_tonemap.frag"}};
    for (P& p : programs) {
        auto r = mShaders.variant({"common_fullscreen.vert", p.frag});
        if (!r) return r.error();
        *p.out = r.value();
    }
    GLuint vao = 0;
    glCreateVertexArrays(1, &vao);
    mEmptyVao = gl::VertexArray(vao);
    const int w = mGBuffer.width, h = mGBuffer.height;
    mAccum = gl::makeTexture2D(GL_RGBA32F, w, h);
    // sRGB-encoded: the GL applies the sRGB transfer function as it stores the view transform's
    // linear output (GL_FRAMEBUFFER_SRGB), cheaper than the shader doing it.
    mLdr = gl::makeTexture2D(GL_SRGB8_ALPHA8, w, h);
    mStatic = gl::makeTexture2D(GL_RGBA32F, w, h);
    for (auto [fb, texture, what] : {std::tuple{&mStaticFb, &mStatic, "static sum"}, std::tuple{&mAccumFb, &mAccum, "accumulation"},
                                      std::tuple{&mLdrFb, &mLdr, "8-bit output"}}) {
        auto made = gl::makeFramebuffer(texture->id(), 0, what);
        if (!made) return made.error();
        *fb = std::move(made.value());
    }
    return okStatus();
}

// With composite_add.frag in use and additive blending on.
void Compositor::addLight(const LightCache& c) const {
    setContributionUniforms(c.scale, c.previewShading);
    glBindTextureUnit(TEX_INPUT, c.contribution.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
}

void Compositor::emission() const {
    glDisable(GL_BLEND);
    glUseProgram(mEmissionProgram);
    glBindTextureUnit(TEX_GBUFFER_EMISSION, mGBuffer.emission.id());
    glBindTextureUnit(TEX_GBUFFER_P, mGBuffer.P.id());
    glBindTextureUnit(TEX_PIXEL_SAMPLES, mGBuffer.pixelSamples.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
}

void Compositor::composite(const Rig& rig, std::map<std::string, LightCache>& lights, bool* fused) {
    std::string structure;
    std::vector<std::string> changed;
    for (const Light& l : rig.lights) {
        if (!l.enabled) continue;
        structure += l.name + '\n';
        const LightCache& c = lights[l.name];
        if (c.version != c.compositedVersion) changed.push_back(l.name);
    }
    glBindVertexArray(mEmptyVao.id());
    glViewport(0, 0, mGBuffer.width, mGBuffer.height);
    const bool sameStructure = structure == mStructure;
    const bool onlyHotChanged = sameStructure && mStaticValid &&
                                (changed.empty() || (changed.size() == 1 && changed[0] == mHot));
    if (!onlyHotChanged && sameStructure && changed.size() == 1) {
        // A new light is being edited: sum every other one once into the static image.
        mHot = changed[0];
        glBindFramebuffer(GL_FRAMEBUFFER, mStaticFb.id());
        emission();
        additive();
        glUseProgram(mAddProgram);
        for (const Light& l : rig.lights)
            if (l.enabled && l.name != mHot) addLight(lights[l.name]);
        mStaticValid = true;
    } else if (!onlyHotChanged) {
        mStaticValid = false;
        mHot.clear();
    }
    mStructure = structure;
    if (fused) *fused = mStaticValid;
    glBindFramebuffer(GL_FRAMEBUFFER, mAccumFb.id());
    if (fused && *fused) {
        // toneMap adds the hot light to the static sum in its view-transform pass.
    } else if (mStaticValid) {
        // Frame = static + the hot light: two draws whatever the number of lights.
        glDisable(GL_BLEND);
        glUseProgram(mAddProgram);
        setContributionUniforms(glm::vec3(1.f), false);
        glBindTextureUnit(TEX_INPUT, mStatic.id());
        glDrawArrays(GL_TRIANGLES, 0, 3);
        additive();
        if (rig.find(mHot)) addLight(lights[mHot]);
    } else {
        emission();
        additive();
        glUseProgram(mAddProgram);
        for (const Light& l : rig.lights)
            if (l.enabled) addLight(lights[l.name]);
    }
    glDisable(GL_BLEND);
    for (const Light& l : rig.lights) {
        if (l.enabled) lights[l.name].compositedVersion = lights[l.name].version;
    }
}

Status Compositor::toneMap(const Rig& rig, const std::map<std::string, LightCache>& lights, bool fused) {
    glBindFramebuffer(GL_FRAMEBUFFER, mLdrFb.id());
    glViewport(0, 0, mGBuffer.width, mGBuffer.height);
    glDisable(GL_BLEND);
    glBindVertexArray(mEmptyVao.id());
    if (fused) {
        // Static sum + the hot light, exposure and view transform in one pass.
        auto program = mShaders.variant({"common_fullscreen.vert", "composite_tonemap.frag"}, "#define TONEMAP_ADD_HOT 1\n");
        if (!program) return program.error();
        glUseProgram(program.value());
        glBindTextureUnit(TEX_INPUT, mStatic.id());
        const auto hot = lights.find(mHot);
        const Light* hotLight = rig.find(mHot);
        if (hot != lights.end() && hotLight && hotLight->enabled && hot->second.contribution) {
            setContributionUniforms(hot->second.scale, hot->second.previewShading);
            glBindTextureUnit(TEX_INPUT_HOT, hot->second.contribution.id());
        } else {
            setContributionUniforms(glm::vec3(0.f), false);
            glBindTextureUnit(TEX_INPUT_HOT, mStatic.id());
        }
    } else {
        glUseProgram(mTonemapProgram);
        glBindTextureUnit(TEX_INPUT, mAccum.id());
    }
    glEnable(GL_FRAMEBUFFER_SRGB);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glDisable(GL_FRAMEBUFFER_SRGB); // and read back the stored (encoded) bytes unchanged
    return okStatus();
}

Status Compositor::startReadBack() {
    const size_t bytes = size_t(mGBuffer.width) * size_t(mGBuffer.height) * 4;
    if (!mReadback) {
        const GLbitfield map = GL_MAP_READ_BIT | GL_MAP_PERSISTENT_BIT | GL_MAP_COHERENT_BIT;
        mReadback = gl::makeBuffer(nullptr, bytes, map | GL_CLIENT_STORAGE_BIT);
        mReadbackPixels = static_cast<const uint8_t*>(glMapNamedBufferRange(mReadback.id(), 0, GLsizeiptr(bytes), map));
        if (!mReadbackPixels) return makeError(ErrorCode::GpuError, "cannot map the frame's read-back buffer");
    }
    glBindFramebuffer(GL_READ_FRAMEBUFFER, mLdrFb.id());
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glBindBuffer(GL_PIXEL_PACK_BUFFER, mReadback.id());
    glReadPixels(0, 0, mGBuffer.width, mGBuffer.height, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
    glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    return okStatus();
}

Image8 Compositor::readBackPixels() const {
    Image8 img;
    img.width = mGBuffer.width;
    img.height = mGBuffer.height;
    const size_t bytes = size_t(img.width) * size_t(img.height) * 4;
    img.rgba.resize(bytes);
    // Several threads copy: one memcpy of a 1080p frame takes longer than its transfer.
    const size_t parts = std::clamp<size_t>(bytes / (1u << 20), 1, 8);
    const size_t chunk = (bytes + parts - 1) / parts;
    WorkerPool::shared().run(int(parts), [&](int i) {
        const size_t at = std::min(bytes, size_t(i) * chunk);
        std::memcpy(img.rgba.data() + at, mReadbackPixels + at, std::min(chunk, bytes - at));
    });
    return img;
}

Result<ImageF> Compositor::readFloat(gl::Context& context, GLuint texture, const char* what, glm::vec3 scale) const {
    ImageF img;
    img.width = mGBuffer.width;
    img.height = mGBuffer.height;
    img.rgba.resize(size_t(img.width) * size_t(img.height) * 4);
    glGetTextureImage(texture, 0, GL_RGBA, GL_FLOAT, GLsizei(img.rgba.size() * sizeof(float)), img.rgba.data());
    if (scale != glm::vec3(1.f)) {
        for (size_t i = 0; i < img.rgba.size(); i += 4)
            for (int k = 0; k < 3; ++k) { // as scaledContribution (common_uniforms.glsl)
                img.rgba[i + size_t(k)] = std::min(img.rgba[i + size_t(k)] * scale[k], RADIANCE_LIMIT);
            }
    }
    if (auto s = context.check(what); !s) return s.error();
    return img;
}

} // namespace dfb::engine
