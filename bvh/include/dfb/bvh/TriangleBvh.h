#pragma once
// A bounding-volume hierarchy of world-space triangles for ray queries on the CPU (Embree 3,
// hidden in bvh/src/TriangleBvh.cpp; library dfb_bvh): what the Picker casts its rays against,
// what the bake traces the environment's visibility with (gbuffer/src/EnvTransfer.cpp), and the
// tests' reference visibility (tests/support/RayCaster.h wraps it). Its own library so that the
// bake (dfb_gbuffer) can use it without depending on the relight engine.
//
// Threading: add meshes and commit() on one thread; after commit() the queries are const and
// may run on any number of threads at once (Embree's rtcIntersect1 / rtcOccluded1 are).

#include <glm/glm.hpp>

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

namespace dfb {

/// The first triangle a ray meets.
struct BvhHit {
    float t = 0.f;        ///< ray parameter: the hit is from + t (to - from), in [tnear, tfar]
    uint32_t mesh = 0;    ///< which addMesh() call the triangle came from, 0-based
    uint32_t triangle = 0; ///< the triangle within that mesh (indices[3 * triangle .. + 2])
    float u = 0.f, v = 0.f; ///< barycentrics: hit = (1 - u - v) a + u b + v c of the triangle's corners
};

class TriangleBvh {
public:
    TriangleBvh();
    ~TriangleBvh();
    TriangleBvh(const TriangleBvh&) = delete;
    TriangleBvh& operator=(const TriangleBvh&) = delete;

    /// Adds world-space triangles: 3 indices each into `positions` (a trailing partial triangle
    /// is ignored; every index must be < positions.size()). The data is copied. Call commit()
    /// after the last mesh; meshes added after a commit need another.
    void addMesh(const std::vector<glm::vec3>& positions, const std::vector<uint32_t>& indices);
    /// Builds the hierarchy (Embree's medium build quality).
    void commit();

    /// True when a triangle lies on the segment from `from` to `to` with the ends excluded by
    /// `eps`, a fraction of the segment's length: the ray parameter in (eps, 1 - eps).
    bool occluded(const glm::vec3& from, const glm::vec3& to, float eps = 1e-4f) const;
    /// The first triangle on the segment from `from` to `to` with parameter t in [tnear, tfar]
    /// (fractions of the segment, as occluded()), nearest `from`; nothing when none.
    std::optional<BvhHit> intersect(const glm::vec3& from, const glm::vec3& to, float tnear, float tfar) const;

    /// Triangles added so far.
    size_t triangleCount() const;

private:
    struct Impl;
    std::unique_ptr<Impl> mImpl;
};

} // namespace dfb
