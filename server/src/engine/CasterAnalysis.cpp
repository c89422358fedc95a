#include "CasterAnalysis.h"

#include <meshoptimizer.h>

#include <chrono>

#include <dfb/server/AreaPattern.h>

#include "GpuInterface.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string_view>
#include <unordered_map>

namespace dfb {

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
            part.objectId = p.objectId;
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

} // namespace dfb

namespace dfb::engine {

gl::VertexArray positionVao(const gl::Buffer& positions, const gl::Buffer& indices) {
    GLuint vao = 0;
    glCreateVertexArrays(1, &vao);
    glVertexArrayVertexBuffer(vao, 0, positions.id(), 0, sizeof(glm::vec3));
    glVertexArrayElementBuffer(vao, indices.id());
    glEnableVertexArrayAttrib(vao, ATTR_POSITION);
    glVertexArrayAttribFormat(vao, ATTR_POSITION, 3, GL_FLOAT, GL_FALSE, 0);
    glVertexArrayAttribBinding(vao, ATTR_POSITION, 0);
    return gl::VertexArray(vao);
}

void Casters::upload(const ShadowGeometry& casters, const DeepBuffer& g) {
    mScene.min = glm::vec3(1e30f);
    mScene.max = glm::vec3(-1e30f);
    for (const glm::vec3& p : casters.positions) {
        mScene.min = glm::min(mScene.min, p);
        mScene.max = glm::max(mScene.max, p);
    }
    // Receivers bound the scene too (a shot may be relit with fewer casters than it shows).
    mReceivers.min = glm::vec3(1e30f);
    mReceivers.max = glm::vec3(-1e30f);
    for (size_t i = 0; i < g.sampleCount(); ++i) {
        if (g.A[i] <= 0.f) continue;
        glm::vec3 p(g.P[i * 3], g.P[i * 3 + 1], g.P[i * 3 + 2]);
        mScene.min = glm::min(mScene.min, p);
        mScene.max = glm::max(mScene.max, p);
        mReceivers.min = glm::min(mReceivers.min, p);
        mReceivers.max = glm::max(mReceivers.max, p);
    }
    if (mReceivers.min.x > mReceivers.max.x) mReceivers = Box{};
    if (mScene.min.x > mScene.max.x) mScene = Box{};
    // Zero-sized buffer storage is a GL error: a shot without casters gets one dummy element.
    const glm::vec3 dummyVertex(0.f);
    const uint32_t dummyIndex = 0;
    mVbo = casters.positions.empty() ? gl::makeBuffer(&dummyVertex, sizeof dummyVertex)
                                     : gl::makeBuffer(casters.positions.data(), casters.positions.size() * sizeof(glm::vec3));
    mIbo = casters.indices.empty() ? gl::makeBuffer(&dummyIndex, sizeof dummyIndex)
                                   : gl::makeBuffer(casters.indices.data(), casters.indices.size() * sizeof(uint32_t));
    mVertexCount = GLuint(casters.positions.size());
    mIndexCount = GLsizei(casters.indices.size());
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
    mPlanesSkippable = !mPlanes.empty() && mPlanarStart < mIndexCount;
    // Orient each plane towards the receivers; a plane with receivers on both sides is never left
    // out.
    const float eps = 1e-4f * glm::length(mScene.max - mScene.min);
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
    mVao = positionVao(mVbo, mIbo);
    mSoft = simplify(casters, SOFT_CASTER_ERROR);
    mSun = simplify(casters, SUN_CASTER_ERROR);
}

// Simplified casters (area lights': docs/lighting.md, "Area lights", Shadows; the environment's
// suns', within half a texel of their maps): each of the three ranges
// (closed meshes, open meshes, open planar meshes) welded by position
// (meshopt_generateShadowIndexBuffer: normals and seams do not matter to a depth pass) and
// simplified (meshopt_simplify, quadric error, Garland and Heckbert 1997) within
// `relativeError` of the scene's diagonal. A grid of m x n maps draws every caster m x n times,
// and llvmpipe's cost per map is the triangles' (about 11 ms per 100k triangles), not the texels';
// the grid's shadows are soft, so detail below the error does not show.
Casters::Simplified Casters::simplify(const ShadowGeometry& casters, float relativeError) const {
    const auto t0 = std::chrono::steady_clock::now();
    Simplified set;
    const float diagonal = glm::length(mScene.max - mScene.min);
    std::vector<uint32_t> out;
    auto range = [&](size_t from, size_t to) {
        if (to <= from || casters.positions.empty()) return;
        const size_t n = to - from;
        std::vector<uint32_t> welded(n), simplified(n);
        meshopt_generateShadowIndexBuffer(welded.data(), casters.indices.data() + from, n, casters.positions.data(), casters.positions.size(),
                                          sizeof(glm::vec3), sizeof(glm::vec3));
        const float scale = meshopt_simplifyScale(&casters.positions[0].x, casters.positions.size(), sizeof(glm::vec3));
        const float error = scale > 0.f ? relativeError * diagonal / scale : 0.f;
        const size_t kept = meshopt_simplify(simplified.data(), welded.data(), n, &casters.positions[0].x, casters.positions.size(),
                                             sizeof(glm::vec3), 0, error);
        out.insert(out.end(), simplified.begin(), simplified.begin() + ptrdiff_t(kept / 3 * 3));
    };
    range(0, size_t(mClosedIndexCount));
    set.closedCount = GLsizei(out.size());
    range(size_t(mClosedIndexCount), size_t(mPlanarStart));
    set.planarStart = GLsizei(out.size());
    range(size_t(mPlanarStart), size_t(mIndexCount));
    set.count = GLsizei(out.size());
    // Their own vertices, only those they use: a bent area light's interior lights deform every
    // vertex of their casters per map (BendyShadow), a few hundred instead of the scene's.
    std::vector<glm::vec3> positions;
    if (!out.empty()) {
        std::vector<uint32_t> remap(casters.positions.size());
        positions.resize(meshopt_optimizeVertexFetchRemap(remap.data(), out.data(), out.size(), casters.positions.size()));
        meshopt_remapVertexBuffer(positions.data(), casters.positions.data(), casters.positions.size(), sizeof(glm::vec3), remap.data());
        meshopt_remapIndexBuffer(out.data(), out.data(), out.size(), remap.data());
    }
    const uint32_t dummyIndex = 0;
    const glm::vec3 dummyVertex(0.f);
    set.ibo = out.empty() ? gl::makeBuffer(&dummyIndex, sizeof dummyIndex) : gl::makeBuffer(out.data(), out.size() * sizeof(uint32_t));
    set.vbo = positions.empty() ? gl::makeBuffer(&dummyVertex, sizeof dummyVertex)
                                : gl::makeBuffer(positions.data(), positions.size() * sizeof(glm::vec3));
    set.vertexCount = GLuint(positions.size());
    set.vao = positionVao(set.vbo, set.ibo);
    set.buildMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return set;
}

void Casters::Simplified::draw(GLsizei n, GLsizei instances) const {
    glBindVertexArray(vao.id());
    const GLsizei closed = std::min(n, closedCount);
    if (closed > 0) {
        glEnable(GL_CULL_FACE);
        glCullFace(GL_FRONT);
        glDrawElementsInstanced(GL_TRIANGLES, closed, GL_UNSIGNED_INT, nullptr, instances);
        glDisable(GL_CULL_FACE);
    }
    if (n > closed) {
        glDrawElementsInstanced(GL_TRIANGLES, n - closed, GL_UNSIGNED_INT, reinterpret_cast<const void*>(size_t(closed) * sizeof(uint32_t)),
                                instances);
    }
}

// A plane cannot occlude anything when the light is on the receivers' side of it: a spot's, point
// light's or sun's rays from a receiver to the light stay on that side (half-spaces are convex); a
// BendyLight's light travels along its flow lines, which must not reach the plane
// (lightmath::flowLinesMissPlane: tubes clear of it, or descending towards it).
GLsizei Casters::indicesFor(const Light& l, const lightmath::Chain<float>& chain) const {
    if (!mPlanesSkippable) return mIndexCount;
    const float eps = 1e-4f * glm::length(mScene.max - mScene.min);
    const glm::vec3 pos = toGlm(l.position), axis = glm::normalize(toGlm(l.direction));
    for (const glm::vec4& plane : mPlanes) {
        const glm::vec3 n(plane);
        auto dist = [&](const glm::vec3& p) { return glm::dot(n, p) - plane.w; };
        bool clear = false;
        if (l.type == LightType::Directional) {
            clear = glm::dot(n, -axis) > 1e-6f;
        } else if (l.type == LightType::Bendy) {
            clear = lightmath::flowLinesMissPlane(chain, n, plane.w, eps);
        } else if (l.type == LightType::Area) {
            // Every point of the emitter (its corners: the plane's side is linear) in front.
            const auto f = areaFrameOf<float>(l);
            clear = true;
            for (int c = 0; c < 4; ++c)
                clear = clear && dist(f.centre + f.right * ((c & 1 ? 0.5f : -0.5f) * f.width) +
                                      f.up * ((c & 2 ? 0.5f : -0.5f) * f.height)) > eps;
        } else {
            clear = dist(pos) > eps;
        }
        if (!clear) return mIndexCount;
    }
    return mPlanarStart;
}

// Closed meshes are drawn with the faces towards the light culled (their far side casts the same
// shadow on everything else and on their own unlit side; llvmpipe rasterises about half as much),
// the rest two-sided. Meshes whose box lies wholly outside one side of the frustum (left, right,
// bottom or top; near and far are left alone) are skipped: they cannot cover a texel, and llvmpipe
// would still transform and clip every one of their triangles (a point light's cube face sees
// about a sixth of the scene).
void Casters::draw(GLsizei count, const glm::mat4& worldToClip, GLsizei instances) const {
    auto outside = [&](const ShadowGeometry::Part& part) {
        if (!std::isfinite(part.min.x) || instances > 1) return false;
        // A bit per clip-space side plane (w + x, w - x, w + y, w - y >= 0) that every corner
        // of the box is outside of.
        unsigned allOut = 15u;
        for (int k = 0; k < 8 && allOut; ++k) {
            const glm::vec4 clip = worldToClip * glm::vec4(boxCorner(part.min, part.max, k), 1.f);
            const unsigned out = (clip.w + clip.x < 0.f ? 1u : 0u) | (clip.w - clip.x < 0.f ? 2u : 0u) |
                                 (clip.w + clip.y < 0.f ? 4u : 0u) | (clip.w - clip.y < 0.f ? 8u : 0u);
            allOut &= out;
        }
        return allOut != 0u;
    };
    glBindVertexArray(mVao.id());
    // Runs of consecutive drawn meshes become one draw; the closed ones with front faces culled.
    GLsizei runStart = 0, runEnd = 0;
    bool runClosed = false;
    auto flush = [&]() {
        if (runEnd <= runStart) return;
        if (runClosed) {
            glEnable(GL_CULL_FACE);
            glCullFace(GL_FRONT);
        }
        glDrawElementsInstanced(GL_TRIANGLES, runEnd - runStart, GL_UNSIGNED_INT,
                                reinterpret_cast<const void*>(size_t(runStart) * sizeof(uint32_t)), instances);
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

} // namespace dfb::engine
