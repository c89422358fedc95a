#include "ShadowMaps.h"

#include "GpuInterface.h"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>

namespace dfb::engine {
namespace {

// Depth-only state of every shadow pass into `framebuffer`, `size` texels square. Casters are not
// assumed closed (Casters::draw culls the closed ones itself). No slope-scaled offset: it pushes a
// caster back by its own depth slope, which is steep exactly where casters meet receivers at
// contacts and grazing lines, pushing shadows off their contacts (issue 16). Acne is left to the
// receiver-plane depth bias of the lookup (LightShading.cpp, lightBlock; filteredShadowPlane in
// common_uniforms.glsl); two units of the depth format's resolution only absorb the rounding
// between the rasterised depth and the relight shaders' projection of it.
void beginDepthPass(GLuint framebuffer, int size) {
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
    glViewport(0, 0, size, size);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    glDisable(GL_CULL_FACE);
    glDisable(GL_BLEND);
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(0.f, 2.f);
}

void endDepthPass() {
    glDisable(GL_POLYGON_OFFSET_FILL);
    glDisable(GL_DEPTH_TEST);
}

void clearDepth(GLuint framebuffer) {
    const float one = 1.f;
    glClearNamedFramebufferfv(framebuffer, GL_DEPTH, 0, &one);
}

// Shadow maps are read as raw depths: the relight shaders gather four texels and compare each
// with the receiver plane's depth at its centre (filteredShadowPlane in common_uniforms.glsl,
// filteredShadowCube in relight_spot.frag).
void rawDepth(GLuint texture) {
    glTextureParameteri(texture, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(texture, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTextureParameteri(texture, GL_TEXTURE_COMPARE_MODE, GL_NONE);
}

} // namespace

int shadowSizeFor(const Light& l, bool preview) {
    return preview ? std::min(l.shadowMapSize, std::max(256, l.shadowMapSize / 4)) : l.shadowMapSize;
}

Status ShadowMaps::init() {
    auto depth = mShaders.variant({"shadow_depth.vert", "shadow_depth.frag"});
    if (!depth) return depth.error();
    mDepthProgram = depth.value();
    return mBendy.init();
}

Status ShadowMaps::render(LightCache& c, bool preview, int subdivisionLimit) {
    const Light& l = c.params;
    c.previewShadow = preview && shadowSizeFor(l, true) != l.shadowMapSize;
    const int size = shadowSizeFor(l, preview);
    if (auto s = l.type == LightType::Point ? renderCube(c, size) : renderPlanar(c, size, subdivisionLimit); !s) return s;
    c.hasShadow = true;
    return okStatus();
}

Status ShadowMaps::renderPlanar(LightCache& c, int size, int subdivisionLimit) {
    const Light& l = c.params;
    if (!c.shadowMap || c.shadowIsCube || c.shadowSize != size) {
        c.shadowIsCube = false;
        c.shadowSize = size;
        c.shadowMap = gl::makeTexture2D(GL_DEPTH_COMPONENT32F, c.shadowSize, c.shadowSize);
        rawDepth(c.shadowMap.id());
        auto fb = gl::makeFramebuffer(0, c.shadowMap.id(), "shadow map of light '" + l.name + "'");
        if (!fb) return fb.error();
        c.shadowFb = std::move(fb.value());
    }
    c.worldToLightClip = lightViewProj(l, mCasters.scene(), mCasters.receivers());
    LightBlock block{};
    block.worldToLightClip = c.worldToLightClip;
    mLight.upload(block);
    beginDepthPass(c.shadowFb.id(), c.shadowSize);
    clearDepth(c.shadowFb.id());
    if (l.type == LightType::Bendy) {
        if (auto s = mBendy.draw(c, subdivisionLimit); !s) return s;
    } else {
        glUseProgram(mDepthProgram);
        c.casterIndexCount = mCasters.indicesFor(l, c.chain);
        mCasters.draw(c.casterIndexCount, c.worldToLightClip);
    }
    endDepthPass();
    return okStatus();
}

// Six faces into one depth cube texture, each face a 90-degree perspective.
Status ShadowMaps::renderCube(LightCache& c, int size) {
    const Light& l = c.params;
    if (!c.shadowMap || !c.shadowIsCube || c.shadowSize != size) {
        c.shadowIsCube = true;
        c.shadowSize = size;
        GLuint id = 0;
        glCreateTextures(GL_TEXTURE_CUBE_MAP, 1, &id);
        c.shadowMap = gl::Texture(id);
        glTextureStorage2D(id, 1, GL_DEPTH_COMPONENT32F, size, size);
        rawDepth(id);
        glTextureParameteri(id, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTextureParameteri(id, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        GLuint fb = 0;
        glCreateFramebuffers(1, &fb);
        c.shadowFb = gl::Framebuffer(fb);
        glNamedFramebufferDrawBuffer(fb, GL_NONE);
    }
    // Filtering across face edges (the PCF taps of a direction near an edge reach the next face).
    glEnable(GL_TEXTURE_CUBE_MAP_SEAMLESS);
    const glm::vec3 pos = toGlm(l.position);
    const glm::vec2 depth = perspectiveDepthRange(pos, mCasters.scene());
    c.cubeNearFar = depth;
    const glm::mat4 proj = glm::perspective(shadowFovyRad(l), 1.f, depth.x, depth.y);
    beginDepthPass(c.shadowFb.id(), size);
    glUseProgram(mDepthProgram);
    c.casterIndexCount = mCasters.indicesFor(l, c.chain);
    for (int face = 0; face < 6; ++face) {
        glNamedFramebufferTextureLayer(c.shadowFb.id(), GL_DEPTH_ATTACHMENT, c.shadowMap.id(), 0, face);
        if (face == 0) {
            if (auto s = gl::checkFramebuffer(c.shadowFb.id(), ("cube shadow map of light '" + l.name + "'").c_str()); !s) return s;
        }
        clearDepth(c.shadowFb.id());
        LightBlock block{};
        block.worldToLightClip = proj * cubeFaceView(pos, face);
        mLight.upload(block);
        mCasters.draw(c.casterIndexCount, block.worldToLightClip);
    }
    endDepthPass();
    return okStatus();
}

} // namespace dfb::engine
