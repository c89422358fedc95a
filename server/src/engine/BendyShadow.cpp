#include "BendyShadow.h"

#include "GpuInterface.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>

namespace dfb::engine {
namespace {

GLuint groupsFor(GLuint items) { return (items + COMPUTE_GROUP_SIZE - 1) / COMPUTE_GROUP_SIZE; }

const void* commandAt(size_t offset) { return reinterpret_cast<const void*>(offset); }

} // namespace

Status BendyShadow::init() {
    // The deform and tessellation programs are variants per number of segments (draw).
    const size_t vertices = std::max<size_t>(mCasters.vertexCount(), mCasters.softVertexCount());
    mDeformed = gl::makeBuffer(nullptr, std::max<size_t>(vertices, 1) * 2 * sizeof(glm::vec4));
    mDeformedTexture = gl::makeBufferTexture(GL_RGBA32F, mDeformed);
    mCasterIndexTexture = gl::makeBufferTexture(GL_R32UI, mCasters.indices());
    mSoftIndexTexture = gl::makeBufferTexture(GL_R32UI, mCasters.softIndices());
    auto classify = mShaders.variant({"bendy_classify.comp"});
    if (!classify) return classify.error();
    mClassifyProgram = classify.value();
    auto flat = mShaders.variant({"shadow_bendy_flat.vert", "shadow_depth.frag"});
    if (!flat) return flat.error();
    mFlatProgram = flat.value();
    const size_t bytes = std::max<size_t>(size_t(mCasters.indexCount()), 3) * sizeof(uint32_t);
    mFlatIndices = gl::makeBuffer(nullptr, bytes);
    mTessIndices = gl::makeBuffer(nullptr, bytes);
    mIndirect = gl::makeBuffer(nullptr, sizeof(BendyDrawCommands), GL_DYNAMIC_STORAGE_BIT);
    GLuint v = 0;
    glCreateVertexArrays(1, &v);
    mFlatVao = gl::VertexArray(v); // positions come from the deformed buffer by index
    glVertexArrayElementBuffer(v, mFlatIndices.id());
    mTessVao = positionVao(mCasters.positions(), mTessIndices);
    mSoftTessVao = positionVao(mCasters.softPositions(), mTessIndices);
    return okStatus();
}

// Casters are subdivided and mapped Q -> Q' in the tessellation stages where the deformation bends
// their edges; the rest are drawn plain from their deformed vertices.
Status BendyShadow::draw(LightCache& c, int subdivisionLimit) {
    const Light& l = c.params;
    uploadBendy(c);
    const std::string segments = mShaders.generic() ? "" : "#define BENDY_K " + std::to_string(c.bendySegments()) + "\n";
    auto deform = mShaders.variant({"bendy_deform.comp"}, segments);
    if (!deform) return deform.error();
    auto tess = mShaders.variant({"shadow_bendy.vert", "shadow_bendy.tesc", "shadow_bendy.tese", "shadow_bendy.frag"}, segments);
    if (!tess) return tess.error();
    // Deform every caster vertex once, then draw patches that reuse it.
    const GLuint vertices = c.softCasters ? mCasters.softVertexCount() : mCasters.vertexCount();
    glUseProgram(deform.value());
    glUniform1ui(LOC_DEFORM_VERTEX_COUNT, vertices);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, SSBO_CASTER_POSITIONS,
                     c.softCasters ? mCasters.softPositions().id() : mCasters.positions().id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, SSBO_DEFORMED, mDeformed.id());
    glDispatchCompute(groupsFor(vertices), 1, 1);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    const float texelSize = texelPerDistance(l, c.shadowSize);
    // Sort the triangles: plain draw where no edge needs subdividing, tessellation elsewhere.
    const auto closed = uint32_t(c.softCasters ? mCasters.softClosedIndexCount() : mCasters.closedIndexCount());
    c.casterIndexCount = mCasters.indicesFor(l, c.chain);
    if (c.softCasters) c.casterIndexCount = mCasters.softIndicesFor(c.casterIndexCount);
    const GLuint triangles = GLuint(c.casterIndexCount / 3);
    auto classify = [&](int maxLevel) {
        const BendyDrawCommands commands{{0, 1, 0, 0, 0}, {0, 1, closed, 0, 0}, {0, 1, 0, 0, 0}, {0, 1, closed, 0, 0}, 0, {}};
        glNamedBufferSubData(mIndirect.id(), 0, sizeof commands, &commands);
        glUseProgram(mClassifyProgram);
        glUniform1ui(LOC_CLASSIFY_TRIANGLE_COUNT, triangles);
        glUniform1f(LOC_CLASSIFY_MAX_LEVEL, float(maxLevel));
        glUniform1f(LOC_CLASSIFY_TEXEL_PER_DISTANCE, texelSize);
        glUniform1ui(LOC_CLASSIFY_CLOSED_TRIANGLES, closed / 3);
        glBindTextureUnit(TEX_DEFORMED, mDeformedTexture.id());
        glBindTextureUnit(TEX_CASTER_INDICES, c.softCasters ? mSoftIndexTexture.id() : mCasterIndexTexture.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, SSBO_FLAT_INDICES, mFlatIndices.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, SSBO_TESS_INDICES, mTessIndices.id());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, SSBO_DRAW_COMMANDS, mIndirect.id());
        glDispatchCompute(groupsFor(triangles), 1, 1);
        glMemoryBarrier(GL_COMMAND_BARRIER_BIT | GL_ELEMENT_ARRAY_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT |
                        GL_BUFFER_UPDATE_BARRIER_BIT);
    };
    classify(subdivisionLimit);
    // Bound the tessellator's work: a chain that narrows sharply (a local shadow scale's waist)
    // asks the highest level of most triangles, millions of triangles and seconds a frame on
    // llvmpipe. Over MAX_TESS_TRIANGLES the sort runs again with the limit lowered so that the
    // estimate (level squared per triangle) fits: the map then is coarser, never late. One read
    // back of a word per deformed map.
    uint32_t work = 0;
    glGetNamedBufferSubData(mIndirect.id(), offsetof(BendyDrawCommands, tessWork), sizeof work, &work);
    int level = subdivisionLimit;
    if (work > MAX_TESS_TRIANGLES) {
        level = std::max(1, int(float(subdivisionLimit) * std::sqrt(float(MAX_TESS_TRIANGLES) / float(work))));
        classify(level);
    }
    c.appliedSubdivision = level;
    glBindBuffer(GL_DRAW_INDIRECT_BUFFER, mIndirect.id());
    glUseProgram(mFlatProgram);
    glBindVertexArray(mFlatVao.id());
    // Closed meshes front-face culled, as Casters::draw (the deformation keeps the winding).
    glEnable(GL_CULL_FACE);
    glCullFace(GL_FRONT);
    glDrawElementsIndirect(GL_TRIANGLES, GL_UNSIGNED_INT, commandAt(offsetof(BendyDrawCommands, plainClosed)));
    glDisable(GL_CULL_FACE);
    glDrawElementsIndirect(GL_TRIANGLES, GL_UNSIGNED_INT, commandAt(offsetof(BendyDrawCommands, plainOpen)));
    glUseProgram(tess.value());
    glBindVertexArray(c.softCasters ? mSoftTessVao.id() : mTessVao.id());
    glUniform1f(LOC_TESS_MAX_LEVEL, float(level));
    glUniform1f(LOC_TESS_TEXEL_PER_DISTANCE, texelSize);
    glPatchParameteri(GL_PATCH_VERTICES, 3);
    glEnable(GL_CULL_FACE);
    glCullFace(GL_FRONT);
    glDrawElementsIndirect(GL_PATCHES, GL_UNSIGNED_INT, commandAt(offsetof(BendyDrawCommands, tessClosed)));
    glDisable(GL_CULL_FACE);
    glDrawElementsIndirect(GL_PATCHES, GL_UNSIGNED_INT, commandAt(offsetof(BendyDrawCommands, tessOpen)));
    glBindBuffer(GL_DRAW_INDIRECT_BUFFER, 0);
    c.subdivisionLimit = subdivisionLimit;
    return okStatus();
}

} // namespace dfb::engine
