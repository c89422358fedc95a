#pragma once
// Test support: small hand-made meshes for engine tests (flat-shaded triangles and quads).

#include <dfb/gbuffer/Scene.h>

#include <glm/glm.hpp>

#include <vector>

namespace dfb::test {

/// Flat-shaded triangles (one vertex per corner, three corners per triangle), counter-clockwise
/// from the front, as one part of object `id` with material 1.
inline MeshPart flatPart(uint32_t id, const std::vector<glm::vec3>& corners) {
    MeshPart p;
    p.objectId = id;
    p.materialId = 1;
    for (size_t t = 0; t + 2 < corners.size(); t += 3) {
        const glm::vec3 n = glm::normalize(glm::cross(corners[t + 1] - corners[t], corners[t + 2] - corners[t]));
        for (int k = 0; k < 3; ++k) {
            p.indices.push_back(uint32_t(p.positions.size()));
            p.positions.push_back(corners[t + size_t(k)]);
            p.normals.push_back(n);
        }
    }
    return p;
}

/// A quad a, b, c, d (counter-clockwise from its front) as two triangles.
inline void quad(std::vector<glm::vec3>& out, glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d) {
    out.insert(out.end(), {a, b, c, a, c, d});
}

} // namespace dfb::test
