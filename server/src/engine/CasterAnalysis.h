#pragma once
// Shadow casters: the CPU analysis that sorts a scene's meshes for the shadow maps (closed meshes
// first, then open ones, then open planar ones; runs of triangles with their boxes; Engine.h's
// shadowCasters, isClosedMesh and meshPlane live in CasterAnalysis.cpp), and their upload as one
// vertex and index buffer with what a shadow map needs to leave parts out.

#include "LightFrustum.h"

#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/gl/Objects.h>
#include <dfb/lightmath/BendyLight.h>
#include <dfb/server/Engine.h>

#include <vector>

namespace dfb::engine {

/// A vertex array of vec3 positions (ATTR_POSITION) drawn through an index buffer.
gl::VertexArray positionVao(const gl::Buffer& positions, const gl::Buffer& indices);

class Casters {
public:
    /// Uploads the casters (GL thread). The shot's covered samples bound the scene too, and orient
    /// the planes of open planar meshes towards the receivers.
    void upload(const ShadowGeometry& casters, const DeepBuffer& shot);

    /// Casters and covered receivers, and the receivers alone (zero boxes when there are none).
    const Box& scene() const { return mScene; }
    const Box& receivers() const { return mReceivers; }

    /// How many indices a light's shadow map needs: all, or all but the open planar meshes when
    /// none of them can occlude anything for this light (`chain`: a BendyLight's, as uploaded).
    GLsizei indicesFor(const Light& l, const lightmath::Chain<float>& chain) const;

    /// Draws the undeformed casters up to index `count` into the bound depth target, leaving out
    /// runs whose box lies outside the sides of `worldToClip`'s frustum. `instances` > 1: that
    /// many instances of every run (an area light's layers), none left out.
    void draw(GLsizei count, const glm::mat4& worldToClip, GLsizei instances = 1) const;

    /// Area lights' (and bent area lights' interior lights') simplified casters (simplified within
    /// SOFT_CASTER_ERROR): the count of them standing for `fullCount` of the full ones (indicesFor's
    /// all, or all but the open planar meshes), and their instanced draw (closed meshes with front
    /// faces culled, as draw).
    GLsizei softIndicesFor(GLsizei fullCount) const { return mSoft.indicesFor(fullCount, mIndexCount); }
    void drawSoft(GLsizei count, GLsizei instances) const { mSoft.draw(count, instances); }
    /// Triangles of the simplified casters, and the time simplifying took.
    GLsizei softTriangles() const { return mSoft.count / 3; }
    const gl::Buffer& softIndices() const { return mSoft.ibo; }   // into softPositions()
    const gl::Buffer& softPositions() const { return mSoft.vbo; } // the vertices they use, alone
    GLuint softVertexCount() const { return mSoft.vertexCount; }
    GLsizei softClosedIndexCount() const { return mSoft.closedCount; }
    double softBuildMs() const { return mSoft.buildMs; }

    /// The environment's suns' casters (simplified within SUN_CASTER_ERROR, half a texel of their
    /// maps), as the soft ones: the count standing for `fullCount` and their draw.
    GLsizei sunIndicesFor(GLsizei fullCount) const { return mSun.indicesFor(fullCount, mIndexCount); }
    void drawSun(GLsizei count) const { mSun.draw(count, 1); }
    GLsizei sunTriangles() const { return mSun.count / 3; }

    const gl::Buffer& positions() const { return mVbo; }
    const gl::Buffer& indices() const { return mIbo; }
    GLuint vertexCount() const { return mVertexCount; }
    GLsizei indexCount() const { return mIndexCount; }
    GLsizei closedIndexCount() const { return mClosedIndexCount; }

private:
    // One simplified set of the casters: its own index and vertex buffers, with the full set's
    // three ranges (closed, open, open planar meshes) in the same order.
    struct Simplified {
        gl::Buffer ibo, vbo;
        gl::VertexArray vao;
        GLuint vertexCount = 0;
        GLsizei closedCount = 0, planarStart = 0, count = 0;
        double buildMs = 0.0;
        GLsizei indicesFor(GLsizei fullCount, GLsizei fullIndexCount) const { return fullCount >= fullIndexCount ? count : planarStart; }
        void draw(GLsizei count, GLsizei instances) const;
    };
    Simplified simplify(const ShadowGeometry& casters, float error) const;

    Box mScene, mReceivers;
    gl::Buffer mVbo, mIbo;
    gl::VertexArray mVao;
    GLuint mVertexCount = 0;
    GLsizei mIndexCount = 0;
    GLsizei mClosedIndexCount = 0; // indices[0, this) are closed meshes (ShadowGeometry)
    std::vector<ShadowGeometry::Part> mParts; // the meshes' index ranges and boxes, in index order
    GLsizei mPlanarStart = 0;       // indices[this, end) are open planar meshes, with these planes:
    std::vector<glm::vec4> mPlanes; // oriented so that every receiver is on the positive side
    bool mPlanesSkippable = false;  // ... which holds for all of them (else never left out)
    Simplified mSoft; // area lights' simplified casters (SOFT_CASTER_ERROR)
    Simplified mSun;  // the environment's suns' (SUN_CASTER_ERROR)
};

/// How far area lights' simplified casters may stray from the full ones: this fraction of the
/// scene's diagonal (Casters::simplify; measured in tests/gpu/area_light_test.cpp).
constexpr float SOFT_CASTER_ERROR = 0.002f;
/// How far the environment's suns' simplified casters may stray, as a fraction of the scene's
/// diagonal: half a texel of their ENV_SUN_MAP_SIZE maps, which span at most the diagonal (the
/// directional light's frustum holds the bounding sphere). On the 960x540 tabletop the sun's map
/// went from 100k triangles (10-11 ms of a rotation) to 4,108 (about 2 ms); the errors against the
/// ray-traced reference moved by at most 0.2 points (docs/operations.md).
constexpr float SUN_CASTER_ERROR = 0.5f / float(ENV_SUN_MAP_SIZE);

} // namespace dfb::engine
