// The near-field horizon's bake (dfb/gbuffer/NearField.h; the math of dfb/lightmath/Horizon.h).

#include <dfb/gbuffer/NearField.h>

#include "EnvTracer.h"
#include "HorizonTracer.h"

#include <dfb/bvh/TriangleBvh.h>
#include <dfb/lightmath/Horizon.h>

#include <glm/gtc/packing.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

namespace dfb {
namespace {

static_assert(HORIZON_AZIMUTHS == lightmath::HORIZON_AZIMUTHS, "the file's horizon.h* channels are the light math's azimuths");

using Clock = std::chrono::steady_clock;

// How far rays start off the surface, as a fraction of the scene's bounding radius: the
// environment transfer's (EnvTransfer.cpp) and the tests' rayHair.
constexpr float RAY_HAIR = 1e-5f;
// The search of each azimuth's horizon: the elevation sine stepped by 1 / SCAN_STEPS from 0, then
// the step where it opens halved REFINE_STEPS times (1/256: 0.2 degrees near the plane, where the
// lights the map cannot resolve arrive).
constexpr int SCAN_STEPS = 8, REFINE_STEPS = 5;
// Back faces a sample's rays may start past (see bakeHorizon).
constexpr int MAX_ESCAPES = 4;

// The geometric normal as the relight engine reads it (half floats, GBufferTextures), so that
// both meet horizonFrame's branch on the same side.
glm::vec3 storedNormal(const glm::vec3& Ng) {
    glm::vec3 n;
    for (int c = 0; c < 3; ++c) n[c] = glm::unpackHalf1x16(glm::packHalf1x16(Ng[c]));
    const float len = glm::length(n);
    return len > 0.f ? n / len : glm::vec3(0.f, 0.f, 1.f);
}

} // namespace

HorizonTracer::HorizonTracer(const Scene& scene, float radiusFraction, std::shared_ptr<const TriangleBvh> bvh)
    : mScene(scene), mBvh(bvh ? std::move(bvh) : sceneBvh(scene)) {
    const float sceneRadius = scene.bounds.empty() ? 1.f : std::max(scene.bounds.radius(), 1e-6f);
    mReach = radiusFraction * sceneRadius;
    mHair = RAY_HAIR * sceneRadius;
}

size_t HorizonTracer::trace(const glm::vec3& P, const glm::vec3& geometric, float out[HORIZON_AZIMUTHS]) const {
    const glm::vec3 Ng = storedNormal(geometric);
    glm::vec3 t, bt;
    lightmath::horizonFrame(Ng, t, bt);
    glm::vec3 from = P + Ng * mHair;
    size_t rays = 0;
    // Started inside a mesh (a merged sample's averaged position: inside a curved surface, or
    // inside the corner of two faces a pixel's points fell on): the ray along the normal leaves
    // through the back of a triangle; start past it. An open surface seen from behind is passed
    // too, which can only leave light for the shadow map to stop.
    for (int escape = 0; escape < MAX_ESCAPES; ++escape) {
        ++rays;
        auto hit = mBvh->intersect(from, from + Ng * mReach, 0.f, 1.f);
        if (!hit) break;
        const MeshPart& p = mScene.parts[hit->mesh];
        const glm::vec3 a = p.positions[p.indices[size_t(hit->triangle) * 3]];
        const glm::vec3 e1 = p.positions[p.indices[size_t(hit->triangle) * 3 + 1]] - a;
        const glm::vec3 e2 = p.positions[p.indices[size_t(hit->triangle) * 3 + 2]] - a;
        if (glm::dot(glm::cross(e1, e2), Ng) <= 0.f) break; // a front face: outside
        from += Ng * (hit->t * mReach + mHair);
    }
    auto closed = [&](int k, float sine) {
        ++rays;
        return mBvh->occluded(from, from + mReach * lightmath::horizonDirection(Ng, t, bt, k, sine), 1e-6f);
    };
    for (int k = 0; k < HORIZON_AZIMUTHS; ++k) {
        float h = 0.f;
        if (closed(k, 0.f)) {
            int j = 1;
            while (j <= SCAN_STEPS && closed(k, float(j) / SCAN_STEPS)) ++j;
            if (j > SCAN_STEPS) {
                h = 1.f;
            } else {
                float lo = float(j - 1) / SCAN_STEPS, hi = float(j) / SCAN_STEPS;
                for (int i = 0; i < REFINE_STEPS; ++i) {
                    const float mid = 0.5f * (lo + hi);
                    (closed(k, mid) ? lo : hi) = mid;
                }
                h = hi;
            }
        }
        out[k] = h;
    }
    return rays;
}

Result<HorizonStats> bakeHorizon(const Scene& scene, DeepBuffer& b, float radiusFraction, unsigned threads) {
    if (!(radiusFraction > 0.f && radiusFraction <= MAX_HORIZON_RADIUS_FRACTION)) {
        return makeError(ErrorCode::InvalidValue, "near-field horizon radius " + std::to_string(radiusFraction) +
                                                      " of the scene's radius is out of range (0, " +
                                                      std::to_string(MAX_HORIZON_RADIUS_FRACTION) + "]");
    }
    const size_t n = b.sampleCount();
    if (b.P.size() != n * 3 || b.Ng.size() != n * 3 || b.A.size() != n) {
        return makeError(ErrorCode::InvalidValue, "near-field horizon: the deep buffer's layers are inconsistent");
    }
    const auto t0 = Clock::now();
    const HorizonTracer tracer(scene, radiusFraction);
    std::vector<size_t> covered;
    for (size_t s = 0; s < n; ++s)
        if (b.A[s] > 0.f) covered.push_back(s);
    std::vector<float> horizon(n * HORIZON_AZIMUTHS, 0.f);
    std::atomic<size_t> traced{0};
    HorizonStats stats;
    stats.threads = parallelChunks(covered.size(), threads, [&](size_t first, size_t last) {
        size_t mine = 0;
        for (size_t c = first; c < last; ++c) {
            const size_t s = covered[c];
            mine += tracer.trace(b.position(s), glm::vec3(b.Ng[s * 3], b.Ng[s * 3 + 1], b.Ng[s * 3 + 2]), &horizon[s * HORIZON_AZIMUTHS]);
        }
        traced.fetch_add(mine);
    });
    b.horizon = std::move(horizon);
    b.horizonRadius = tracer.reach();
    stats.samples = covered.size();
    stats.rays = traced.load();
    stats.totalMs = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    return stats;
}

} // namespace dfb
