#include "ShadowMaps.h"

#include "GpuInterface.h"

#include <glm/gtc/matrix_transform.hpp>

#include <dfb/server/AreaPattern.h>

#include <algorithm>
#include <vector>

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

// A depth texture of several faces or layers (a point light's cube map, an area light's 2D array)
// for raw-depth lookups, and a framebuffer without colour for it (the caller attaches a face, or
// every layer).
void makeLayeredDepth(LightCache& c, GLenum target, int size, int layers) {
    GLuint id = 0;
    glCreateTextures(target, 1, &id);
    c.shadowMap = gl::Texture(id);
    if (target == GL_TEXTURE_CUBE_MAP) glTextureStorage2D(id, 1, GL_DEPTH_COMPONENT32F, size, size);
    else glTextureStorage3D(id, 1, GL_DEPTH_COMPONENT32F, size, size, layers);
    rawDepth(id);
    glTextureParameteri(id, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(id, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    GLuint fb = 0;
    glCreateFramebuffers(1, &fb);
    c.shadowFb = gl::Framebuffer(fb);
    glNamedFramebufferDrawBuffer(fb, GL_NONE);
}

} // namespace

int shadowSizeFor(const Light& l, bool preview) {
    if (l.type == LightType::Area || l.type == LightType::BentArea) return l.shadowMapSize;
    return preview ? std::min(l.shadowMapSize, std::max(256, l.shadowMapSize / 4)) : l.shadowMapSize;
}

static_assert(AREA_MAX_LAYERS == MAX_AREA_SHADOW_GRID * MAX_AREA_SHADOW_GRID);

glm::ivec2 areaGridFor(const Light& l, bool preview) {
    const glm::ivec2 g(std::clamp(l.shadowGrid[0], 1, MAX_AREA_SHADOW_GRID), std::clamp(l.shadowGrid[1], 1, MAX_AREA_SHADOW_GRID));
    // A bent area light's interior lights cost a BendyLight each (its inverse mapping per pixel):
    // a preview takes one, the emitter's centre carrying all of it.
    return preview ? glm::min(g, glm::ivec2(l.type == LightType::BentArea ? 1 : 2)) : g;
}

glm::vec2 areaGridPoint(const Light& l, int i, int j, glm::ivec2 grid) {
    const glm::vec2 s((float(i) + 0.5f) / float(grid.x) * 2.f - 1.f, (float(j) + 0.5f) / float(grid.y) * 2.f - 1.f);
    if (l.areaShape != AreaShape::Disk) return 0.5f * s * glm::vec2(l.areaSize[0], l.areaSize[1]);
    // Concentric map of [-1, 1]^2 onto the unit disk: squares' rings to the disk's rings.
    if (s.x == 0.f && s.y == 0.f) return glm::vec2(0.f);
    constexpr float quarterPi = 0.785398163f;
    float r, phi;
    if (std::abs(s.x) > std::abs(s.y)) {
        r = s.x;
        phi = quarterPi * (s.y / s.x);
    } else {
        r = s.y;
        phi = 2.f * quarterPi - quarterPi * (s.x / s.y);
    }
    return 0.5f * l.areaSize[0] * r * glm::vec2(std::cos(phi), std::sin(phi));
}

Status ShadowMaps::init() {
    auto depth = mShaders.variant({"shadow_depth.vert", "shadow_depth.frag"});
    if (!depth) return depth.error();
    mDepthProgram = depth.value();
    if (epoxy_has_gl_extension("GL_ARB_shader_viewport_layer_array")) {
        auto area = mShaders.variant({"shadow_area.vert", "shadow_depth.frag"});
        if (!area) return area.error();
        mAreaProgram = area.value();
    }
    return mBendy.init();
}

Status ShadowMaps::render(LightCache& c, bool preview, int subdivisionLimit) {
    const Light& l = c.params;
    c.previewShadow = preview && shadowSizeFor(l, true) != l.shadowMapSize;
    const int size = shadowSizeFor(l, preview);
    if (l.type != LightType::BentArea) c.interior.clear(); // a light that was a bent area light
    if (l.type == LightType::Area || l.type == LightType::BentArea) {
        c.previewShadow = preview && areaGridFor(l, true) != areaGridFor(l, false);
        if (auto s = l.type == LightType::Area ? renderArea(c, size, preview) : renderBentArea(c, preview, subdivisionLimit); !s) return s;
        c.hasShadow = true;
        return okStatus();
    }
    if (auto s = l.type == LightType::Point ? renderCube(c, size) : renderPlanar(c, size, subdivisionLimit); !s) return s;
    c.hasShadow = true;
    return okStatus();
}

Status ShadowMaps::renderPlanar(LightCache& c, int size, int subdivisionLimit) {
    const Light& l = c.params;
    if (!c.shadowMap || c.shadowTarget != GL_TEXTURE_2D || c.shadowSize != size) {
        c.shadowTarget = GL_TEXTURE_2D;
        c.shadowLayers = 0;
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
        if (c.sunCasters) {
            c.casterIndexCount = mCasters.sunIndicesFor(c.casterIndexCount);
            mCasters.drawSun(c.casterIndexCount);
        } else {
            mCasters.draw(c.casterIndexCount, c.worldToLightClip);
        }
    }
    endDepthPass();
    return okStatus();
}

// A bent area light's interior BendyLights (paper 003 section 4.1), each its deformed map at the
// light's map size: the preview takes fewer of them (areaGridFor), as an area light's layers.
Status ShadowMaps::renderBentArea(LightCache& c, bool preview, int subdivisionLimit) {
    syncInterior(c, areaGridFor(c.params, preview));
    c.casterIndexCount = 0;
    c.appliedSubdivision = subdivisionLimit;
    for (LightCache& interior : c.interior) {
        if (auto s = renderPlanar(interior, c.params.shadowMapSize, subdivisionLimit); !s) return s;
        interior.hasShadow = true;
        c.casterIndexCount += interior.casterIndexCount;
        c.appliedSubdivision = std::min(c.appliedSubdivision, interior.appliedSubdivision);
    }
    c.shadowSize = c.params.shadowMapSize;
    c.shadowLayers = int(c.interior.size());
    c.subdivisionLimit = subdivisionLimit;
    return okStatus();
}

// Six faces into one depth cube texture, each face a 90-degree perspective.
Status ShadowMaps::renderCube(LightCache& c, int size) {
    const Light& l = c.params;
    if (!c.shadowMap || c.shadowTarget != GL_TEXTURE_CUBE_MAP || c.shadowSize != size) {
        c.shadowTarget = GL_TEXTURE_CUBE_MAP;
        c.shadowLayers = 0;
        c.shadowSize = size;
        makeLayeredDepth(c, GL_TEXTURE_CUBE_MAP, size, 6);
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

// An area light's m x n maps (docs/lighting.md, "Area lights"): one depth array, a layer per grid
// point, all from the centre view's projection with the eye moved in the emitter's plane; in clip
// space that only subtracts (P00 dx, P11 dy) from x and y (a symmetric perspective), so the layers'
// offsets are all the shaders need (UBO_AREA_LAYERS). One instanced pass writes every layer
// (gl_Layer from the vertex shader, ARB_shader_viewport_layer_array), or one pass per layer where
// the driver lacks it.
Status ShadowMaps::renderArea(LightCache& c, int size, bool preview) {
    const Light& l = c.params;
    const glm::ivec2 grid = areaGridFor(l, preview);
    const int layers = grid.x * grid.y;
    if (!c.shadowMap || c.shadowTarget != GL_TEXTURE_2D_ARRAY || c.shadowSize != size || c.shadowLayers != layers) {
        c.shadowTarget = GL_TEXTURE_2D_ARRAY;
        c.shadowSize = size;
        c.shadowLayers = layers;
        makeLayeredDepth(c, GL_TEXTURE_2D_ARRAY, size, layers);
        glNamedFramebufferTexture(c.shadowFb.id(), GL_DEPTH_ATTACHMENT, c.shadowMap.id(), 0); // layered: gl_Layer picks
        if (auto s = gl::checkFramebuffer(c.shadowFb.id(), ("area shadow maps of light '" + l.name + "'").c_str()); !s) return s;
    }
    c.areaHalfAngle = areaShadowHalfAngle(l, mCasters.scene());
    c.worldToLightClip = lightViewProj(l, mCasters.scene(), mCasters.receivers());
    // The layers' eyes in the centre view's x (spotFrame right) and y (its up), then clip space.
    const auto f = areaFrameOf<float>(l);
    const lightmath::SpotFrame<float> view = lightmath::spotFrame(f.normal);
    const float p00 = 1.f / std::tan(c.areaHalfAngle); // glm::perspective's x and y scale (aspect 1)
    // The uniform block's whole array (AREA_MAX_LAYERS), the unused layers zero.
    std::vector<glm::vec4> offsets(size_t(AREA_MAX_LAYERS), glm::vec4(0.f));
    for (int j = 0; j < grid.y; ++j)
        for (int i = 0; i < grid.x; ++i) {
            const glm::vec2 g = areaGridPoint(l, i, j, grid);
            const glm::vec3 d = f.right * g.x + f.up * g.y;
            offsets[size_t(j * grid.x + i)] = glm::vec4(p00 * glm::dot(d, view.right), p00 * glm::dot(d, view.up), g.x, g.y);
        }
    c.areaLayers = gl::makeBuffer(offsets.data(), offsets.size() * sizeof(glm::vec4));
    glBindBufferBase(GL_UNIFORM_BUFFER, UBO_AREA_LAYERS, c.areaLayers.id());
    LightBlock block{};
    block.worldToLightClip = c.worldToLightClip;
    mLight.upload(block);
    beginDepthPass(c.shadowFb.id(), size);
    c.casterIndexCount = mCasters.softIndicesFor(mCasters.indicesFor(l, c.chain));
    if (mAreaProgram) {
        clearDepth(c.shadowFb.id());
        glUseProgram(mAreaProgram);
        mCasters.drawSoft(c.casterIndexCount, layers);
    } else {
        glUseProgram(mDepthProgram);
        for (int k = 0; k < layers; ++k) {
            glNamedFramebufferTextureLayer(c.shadowFb.id(), GL_DEPTH_ATTACHMENT, c.shadowMap.id(), 0, k);
            clearDepth(c.shadowFb.id());
            LightBlock layer = block;
            // Clip-space x and y minus the layer's (constant) offset: the translated eye.
            layer.worldToLightClip[3][0] -= offsets[size_t(k)].x;
            layer.worldToLightClip[3][1] -= offsets[size_t(k)].y;
            mLight.upload(layer);
            mCasters.drawSoft(c.casterIndexCount, 1);
        }
        glNamedFramebufferTexture(c.shadowFb.id(), GL_DEPTH_ATTACHMENT, c.shadowMap.id(), 0);
    }
    endDepthPass();
    return okStatus();
}

} // namespace dfb::engine
