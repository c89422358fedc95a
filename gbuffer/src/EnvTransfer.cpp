// The environment transfer by Monte Carlo over the cosine lobe (dfb/gbuffer/EnvTransfer.h).
//
// Sampling w with density max(0, N.w) / pi turns the transfer (1/pi) integral V max(0, N.w) Y_i dw
// of Sloan, Kautz and Snyder 2002 (section 4) into the plain mean of V(w_k) Y_i(w_k): the cosine
// carries no variance, and no ray is spent where it is 0. The cosine lobe covers only the shading
// normal's hemisphere, which is all max(0, N.w) needs; N and the geometric normal Ng differ near
// terminators and under normal maps, and directions below the geometric plane are the sample's
// own surface, so they count as occluded without being traced.

#include <dfb/gbuffer/EnvTransfer.h>

#include "EnvTracer.h"

#include <dfb/lightmath/Environment.h>
#include <dfb/lightmath/Horizon.h>
#include <dfb/lightmath/SphericalHarmonics.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <string>
#include <thread>
#include <vector>

namespace dfb {
namespace {

static_assert(ENV_TRANSFER_COEFFICIENTS == lightmath::SH_TRANSFER_COEFFICIENTS,
              "the file's env.sh* channels are the light math's SH coefficients");

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

constexpr size_t K = ENV_TRANSFER_COEFFICIENTS;

// splitmix64's finaliser (Steele, Lea and Flood, "Fast Splittable Pseudorandom Number
// Generators", OOPSLA 2014): consecutive sample indices give unrelated 64-bit values.
uint64_t mix64(uint64_t x) {
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

// Van der Corput's radical inverse in base 2, in [0, 1).
float radicalInverse2(uint32_t i) {
    i = (i << 16) | (i >> 16);
    i = ((i & 0x00ff00ffu) << 8) | ((i & 0xff00ff00u) >> 8);
    i = ((i & 0x0f0f0f0fu) << 4) | ((i & 0xf0f0f0f0u) >> 4);
    i = ((i & 0x33333333u) << 2) | ((i & 0xccccccccu) >> 2);
    i = ((i & 0x55555555u) << 1) | ((i & 0xaaaaaaaau) >> 1);
    return float(double(i) * (1.0 / 4294967296.0));
}

// An orthonormal frame (t, b, n) about the unit vector n without a branch on its direction
// (Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 2017; the horizon's frame).
void frameAbout(const glm::vec3& n, glm::vec3& t, glm::vec3& b) { lightmath::horizonFrame(n, t, b); }

// How far rays start off the surface, as a fraction of the scene's bounding radius: the tests'
// rayHair (tests/support/ShadowAgreement.h), against self-intersection from the stored positions'
// rounding.
constexpr float RAY_HAIR = 1e-5f;
// Ray length in scene radii: every sample lies in the scene's bounds, so 2 would leave them; 4
// leaves margin for the hair and rounding.
constexpr float RAY_LENGTH = 4.f;
// Samples a worker takes at a time: small enough to balance the curved meshes' costlier rays
// across threads, large enough that the shared counter is not contended.
constexpr size_t CHUNK = 256;

} // namespace

std::shared_ptr<const TriangleBvh> sceneBvh(const Scene& scene) {
    auto bvh = std::make_shared<TriangleBvh>();
    for (const MeshPart& p : scene.parts) bvh->addMesh(p.positions, p.indices);
    bvh->commit();
    return bvh;
}

EnvTracer::EnvTracer(const Scene& scene, int patternRays, std::shared_ptr<const TriangleBvh> bvh) : mBvh(std::move(bvh)) {
    if (!mBvh) {
        const auto t0 = Clock::now();
        mBvh = sceneBvh(scene);
        mBvhMs = msSince(t0);
    }
    const float radius = scene.bounds.empty() ? 1.f : std::max(scene.bounds.radius(), 1e-6f);
    mHair = RAY_HAIR * radius;
    mLength = RAY_LENGTH * radius;
    // Hammersley points, the first coordinate at the strata's centres.
    const size_t m = size_t(std::max(patternRays, 1));
    mPattern.resize(m);
    for (size_t k = 0; k < m; ++k) mPattern[k] = glm::vec2((float(k) + 0.5f) / float(m), radicalInverse2(uint32_t(k)));
}

size_t EnvTracer::estimate(const glm::vec3& P, const glm::vec3& normal, const glm::vec3& geometric, uint64_t seed,
                           size_t first, size_t stride, float out[ENV_TRANSFER_COEFFICIENTS]) const {
    const float len = glm::length(normal);
    const glm::vec3 N = len > 0.f ? normal / len : glm::vec3(0, 1, 0);
    const float lenG = glm::length(geometric);
    const glm::vec3 Ng = lenG > 0.f ? geometric / lenG : N;
    glm::vec3 t, bt;
    frameAbout(N, t, bt);
    // Cranley and Patterson, "Randomization of Number Theoretic Methods for Multiple
    // Integration", SIAM J. Numer. Anal. 1976: one toroidal shift of the whole pattern per point
    // keeps its stratification and makes neighbouring points' errors independent (noise, not a
    // pattern repeated across the image).
    const uint64_t h = mix64(seed);
    const float du = float(double(h >> 40) * (1.0 / 16777216.0));
    const float dv = float(double((h >> 16) & 0xffffffull) * (1.0 / 16777216.0));
    const glm::vec3 from = P + Ng * mHair;
    std::array<float, K> sum{};
    size_t traced = 0, used = 0;
    for (size_t k = first; k < mPattern.size(); k += std::max<size_t>(stride, 1)) {
        ++used;
        float u = mPattern[k].x + du, v = mPattern[k].y + dv;
        u -= std::floor(u);
        v -= std::floor(v);
        // Malley's method: uniform on the disk, lifted to the hemisphere (density cos / pi); u
        // is r^2, so u = 0 is the pole and u -> 1 the horizon.
        const float r = std::sqrt(u), phi = 6.2831853071795864f * v;
        const float z = std::sqrt(std::max(0.f, 1.f - u));
        const glm::vec3 w = glm::normalize(t * (r * std::cos(phi)) + bt * (r * std::sin(phi)) + N * z);
        if (glm::dot(Ng, w) <= 0.f) continue; // below its own surface: occluded
        ++traced;
        if (mBvh->occluded(from, from + w * mLength, 1e-6f)) continue;
        const auto y = lightmath::shEvaluate25(w);
        for (size_t i = 0; i < K; ++i) sum[i] += y[i];
    }
    const float inv = used ? 1.f / float(used) : 0.f;
    for (size_t i = 0; i < K; ++i) out[i] = sum[i] * inv;
    return traced;
}

size_t EnvTracer::lobe(const glm::vec3& P, const glm::vec3& normal, const glm::vec3& geometric, const glm::vec3& view,
                       float roughness, uint64_t seed, size_t first, size_t stride, double out[LOBE_SUMS]) const {
    const float len = glm::length(normal), lenV = glm::length(view);
    const glm::vec3 N = len > 0.f ? normal / len : glm::vec3(0, 1, 0);
    const glm::vec3 V = lenV > 0.f ? view / lenV : N;
    const float lenG = glm::length(geometric);
    const glm::vec3 Ng = lenG > 0.f ? geometric / lenG : N;
    const double alpha = std::max(double(roughness) * double(roughness), lightmath::MIN_ALPHA);
    const double NdotV = glm::dot(N, V);
    glm::vec3 t, bt;
    frameAbout(N, t, bt);
    // Its own shift of the pattern (another hash of the seed than the transfer's): the lobe's and
    // the transfer's errors stay independent.
    const uint64_t h = mix64(seed ^ 0x6c6f6265ull);
    const double du = double(h >> 40) * (1.0 / 16777216.0), dv = double((h >> 16) & 0xffffffull) * (1.0 / 16777216.0);
    const glm::vec3 from = P + Ng * mHair;
    for (int i = 0; i < LOBE_SUMS; ++i) out[i] = 0.0;
    size_t traced = 0;
    for (size_t k = first; k < mPattern.size(); k += std::max<size_t>(stride, 1)) {
        double u = double(mPattern[k].x) + du, v = double(mPattern[k].y) + dv;
        u -= std::floor(u);
        v -= std::floor(v);
        const glm::dvec3 hl = lightmath::ggxHalfVector({u, v}, alpha);
        const glm::vec3 H = glm::normalize(t * float(hl.x) + bt * float(hl.y) + N * float(hl.z));
        const double VdotH = glm::dot(V, H);
        const glm::vec3 L = glm::normalize(2.f * float(VdotH) * H - V);
        const double w = lightmath::ggxLobeWeight(glm::dot(N, L), NdotV, hl.z, VdotH, alpha);
        if (w <= 0) continue;
        out[0] += w;
        if (glm::dot(Ng, L) <= 0.f) continue; // below its own surface: occluded
        ++traced;
        if (mBvh->occluded(from, from + L * mLength, 1e-6f)) continue;
        out[1] += w;
        double* ring = &out[5 + 4 * lightmath::lobeRing(v)];
        ring[0] += w;
        for (int c = 0; c < 3; ++c) out[2 + c] += w * double(L[c]), ring[1 + c] += w * double(L[c]);
    }
    return traced;
}

void EnvTracer::encodeLobe(const double sums[LOBE_SUMS], const glm::vec3& N, const glm::vec3& V, float out[ENV_LOBE_COMPONENTS]) {
    const glm::dvec3 mean(sums[2], sums[3], sums[4]);
    // Nothing of the lobe above the surface (a view past the terminator), or nothing of it
    // visible: the mirror direction stands in (the share says how much it counts).
    glm::dvec3 d = glm::length(mean) > 0.0 ? glm::normalize(mean) : glm::dvec3(glm::reflect(-V, N));
    if (!(glm::length(d) > 0.0)) d = glm::dvec3(N);
    const glm::dvec2 e = lightmath::octEncode(glm::normalize(d));
    out[0] = float(std::clamp(e.x, -1.0, 1.0));
    out[1] = float(std::clamp(e.y, -1.0, 1.0));
    out[2] = sums[0] > 0.0 ? float(std::clamp(sums[1] / sums[0], 0.0, 1.0)) : 1.f;
}

void EnvTracer::encodeRings(const double sums[LOBE_SUMS], const glm::vec3& N, const glm::vec3& V, float out[ENV_RING_COMPONENTS]) {
    static_assert(ENV_LOBE_RINGS == lightmath::ENV_LOBE_RINGS);
    glm::dvec3 mirror = glm::dvec3(glm::reflect(-V, N));
    if (!(glm::length(mirror) > 0.0)) mirror = glm::dvec3(N);
    for (int r = 0; r < ENV_LOBE_RINGS; ++r) {
        const double* ring = &sums[5 + 4 * r];
        const glm::dvec3 moment(ring[1], ring[2], ring[3]);
        const double length = glm::length(moment);
        const glm::dvec2 e = lightmath::octEncode(length > 0.0 ? moment / length : glm::normalize(mirror));
        float* o = &out[4 * r];
        o[0] = float(std::clamp(e.x, -1.0, 1.0));
        o[1] = float(std::clamp(e.y, -1.0, 1.0));
        o[2] = sums[0] > 0.0 ? float(std::clamp(ring[0] / sums[0], 0.0, 1.0)) : 0.f;
        o[3] = ring[0] > 0.0 ? float(lightmath::prefilterRoughnessForResultant(length / ring[0])) : 0.f;
    }
}

unsigned parallelChunks(size_t count, unsigned threads, const std::function<void(size_t, size_t)>& fn,
                        const std::function<void(size_t, size_t)>& progress) {
    unsigned workers = threads ? threads : std::max(1u, std::thread::hardware_concurrency());
    workers = unsigned(std::min<size_t>(workers, std::max<size_t>(1, (count + CHUNK - 1) / CHUNK)));
    std::atomic<size_t> next{0}, done{0};
    auto work = [&](bool reports) {
        for (;;) {
            const size_t first = next.fetch_add(CHUNK);
            if (first >= count) break;
            const size_t last = std::min(first + CHUNK, count);
            fn(first, last);
            const size_t d = done.fetch_add(last - first) + (last - first);
            if (reports && progress) progress(d, count);
        }
    };
    std::vector<std::thread> pool;
    for (unsigned i = 1; i < workers; ++i) pool.emplace_back(work, false);
    work(true);
    for (std::thread& th : pool) th.join();
    if (progress) progress(count, count);
    return workers;
}

Result<EnvTransferStats> bakeEnvTransfer(const Scene& scene, DeepBuffer& b, int rays, unsigned threads,
                                         const std::function<void(size_t, size_t)>& progress) {
    if (rays < 1 || rays > MAX_ENV_RAYS) {
        return makeError(ErrorCode::InvalidValue, "environment rays per sample " + std::to_string(rays) +
                                                      " is out of range (1.." + std::to_string(MAX_ENV_RAYS) + ")");
    }
    const size_t n = b.sampleCount();
    if (b.P.size() != n * 3 || b.N.size() != n * 3 || b.A.size() != n) {
        return makeError(ErrorCode::InvalidValue, "environment transfer: the deep buffer's layers are inconsistent");
    }
    const bool hasNg = b.Ng.size() == n * 3;
    const auto t0 = Clock::now();
    const EnvTracer tracer(scene, rays);
    std::vector<size_t> covered;
    for (size_t s = 0; s < n; ++s)
        if (b.A[s] > 0.f) covered.push_back(s);
    std::vector<float> transfer(n * K, 0.f), lobe(n * ENV_LOBE_COMPONENTS, 0.f), rings(n * ENV_RING_COMPONENTS, 0.f);
    const bool hasRoughness = b.brdf.size() == n * 4;
    std::atomic<size_t> traced{0};
    EnvTransferStats stats;
    // Seeds: the sample index, which for a flat buffer is the pixel's, as in the bake (Baker.cpp).
    stats.threads = parallelChunks(
        covered.size(), threads,
        [&](size_t first, size_t last) {
            size_t mine = 0;
            for (size_t c = first; c < last; ++c) {
                const size_t s = covered[c];
                const glm::vec3 Ng = hasNg ? glm::vec3(b.Ng[s * 3], b.Ng[s * 3 + 1], b.Ng[s * 3 + 2]) : b.normal(s);
                mine += tracer.estimate(b.position(s), b.normal(s), Ng, uint64_t(s), 0, 1, &transfer[s * K]);
                double sums[EnvTracer::LOBE_SUMS];
                const glm::vec3 V = b.camera.towardsEye(b.position(s));
                mine += tracer.lobe(b.position(s), b.normal(s), Ng, V, hasRoughness ? b.brdf[s * 4 + 1] : 1.f, uint64_t(s), 0, 1, sums);
                EnvTracer::encodeLobe(sums, b.normal(s), V, &lobe[s * ENV_LOBE_COMPONENTS]);
                EnvTracer::encodeRings(sums, b.normal(s), V, &rings[s * ENV_RING_COMPONENTS]);
            }
            traced.fetch_add(mine);
        },
        progress);
    b.envTransfer = std::move(transfer);
    b.envLobe = std::move(lobe);
    b.envRings = std::move(rings);
    b.envRays = rays;
    b.envBands = ENV_TRANSFER_BANDS;
    stats.samples = covered.size();
    stats.rays = traced.load();
    stats.bvhMs = tracer.bvhMs();
    stats.totalMs = msSince(t0);
    return stats;
}

} // namespace dfb
