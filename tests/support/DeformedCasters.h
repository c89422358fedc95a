#pragma once
// Test support: a BendyLight's casters deformed on the CPU for a ray-cast reference of its bent
// shadow (paper 000's mapping Q -> Q'), as bendy_light_render_test and engine_shadow_bias_test
// compare the engine's deformed shadow maps with: every triangle split into n x n sub-triangles
// (edges at most `h`, n at most `maxSplit`), each corner mapped in double; sub-triangles with a
// corner outside every tube are dropped.

#include "support/RayCaster.h"

#include <dfb/gbuffer/Scene.h>
#include <dfb/lightmath/BendyLight.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace dfb::test {

inline void addDeformedCasters(RayCaster& rc, const std::vector<MeshPart>& parts, const lightmath::Chain<double>& ch,
                               double h, int maxSplit) {
    std::vector<glm::vec3> pos;
    std::vector<uint32_t> idx;
    auto mapped = [&](const glm::dvec3& q, glm::dvec3& out) {
        const lightmath::TubeCoords<double> c = lightmath::inverseMap(ch, q);
        if (!c.valid) return false;
        out = lightmath::deformedPoint(ch, c);
        return true;
    };
    for (const MeshPart& p : parts) {
        for (size_t t = 0; t + 2 < p.indices.size(); t += 3) {
            const glm::dvec3 a(p.positions[p.indices[t]]), b(p.positions[p.indices[t + 1]]), c(p.positions[p.indices[t + 2]]);
            const double longest = std::max({glm::length(b - a), glm::length(c - b), glm::length(a - c)});
            const int n = std::clamp(int(std::ceil(longest / h)), 1, maxSplit);
            // n x n sub-triangles from barycentric grid points.
            auto grid = [&](int i, int j) { return a + (b - a) * (double(i) / n) + (c - a) * (double(j) / n); };
            for (int i = 0; i < n; ++i)
                for (int j = 0; i + j < n; ++j) {
                    const glm::dvec3 tri[2][3] = {{grid(i, j), grid(i + 1, j), grid(i, j + 1)},
                                                  {grid(i + 1, j), grid(i + 1, j + 1), grid(i, j + 1)}};
                    for (int k = 0; k < (i + j + 1 < n ? 2 : 1); ++k) {
                        glm::dvec3 d[3];
                        if (!mapped(tri[k][0], d[0]) || !mapped(tri[k][1], d[1]) || !mapped(tri[k][2], d[2])) continue;
                        for (const auto& v : d) {
                            idx.push_back(uint32_t(pos.size()));
                            pos.push_back(glm::vec3(v));
                        }
                    }
                }
        }
    }
    rc.addMesh(pos, idx);
    rc.commit();
}

} // namespace dfb::test
