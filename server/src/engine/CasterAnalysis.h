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

    /// Area lights' (and bent area lights' interior lights') simplified casters (buildSoftCasters): the count of them standing for `fullCount`
    /// of the full ones (indicesFor's all, or all but the open planar meshes), and their instanced
    /// draw (closed meshes with front faces culled, as draw).
    GLsizei softIndicesFor(GLsizei fullCount) const;
    void drawSoft(GLsizei count, GLsizei instances) const;
    /// Triangles of the simplified casters, and the time simplifying took.
    GLsizei softTriangles() const { return mSoftCount / 3; }
    const gl::Buffer& softIndices() const { return mSoftIbo; }   // into softPositions()
    const gl::Buffer& softPositions() const { return mSoftVbo; } // the vertices they use, alone
    GLuint softVertexCount() const { return mSoftVertexCount; }
    GLsizei softClosedIndexCount() const { return mSoftClosedCount; }
    double softBuildMs() const { return mSoftBuildMs; }

    const gl::Buffer& positions() const { return mVbo; }
    const gl::Buffer& indices() const { return mIbo; }
    GLuint vertexCount() const { return mVertexCount; }
    GLsizei indexCount() const { return mIndexCount; }
    GLsizei closedIndexCount() const { return mClosedIndexCount; }

private:
    void buildSoftCasters(const ShadowGeometry& casters);

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
    gl::Buffer mSoftIbo, mSoftVbo;  // area lights' simplified casters and their vertices
    GLuint mSoftVertexCount = 0;
    gl::VertexArray mSoftVao;
    GLsizei mSoftClosedCount = 0, mSoftPlanarStart = 0, mSoftCount = 0;
    double mSoftBuildMs = 0.0;
};

/// How far area lights' simplified casters may stray from the full ones: this fraction of the
/// scene's diagonal (Casters::buildSoftCasters; measured in tests/gpu/area_light_test.cpp).
constexpr float SOFT_CASTER_ERROR = 0.002f;

} // namespace dfb::engine
