// The environment transfer by Monte Carlo over the cosine lobe (dfb/gbuffer/EnvTransfer.h).
//
// Sampling w with density max(0, N.w) / pi turns (1/pi) integral V max(0, N.w) Y_i dw into the
// plain mean of V(w_k) Y_i(w_k) (Sloan, Kautz and Snyder 2002, section 4, estimate their
// transfer vectors the same way with uniform sphere samples weighted by the cosine; importance
// sampling the cosine removes that weight's variance). The cosine lobe covers only the shading
// normal's hemisphere, which is all max(0, N.w) needs; N and the geometric normal Ng differ near
// terminators and under normal maps, and directions below the geometric plane are the sample's
// own surface, so they count as occluded without being traced.

#include <dfb/gbuffer/EnvTransfer.h>

#include <dfb/bvh/TriangleBvh.h>
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

static_assert(ENV_TRANSFER_COEFFICIENTS == lightmath::SH_COEFFICIENTS,
              "the file's env.sh* channels are the light math's SH coefficients");

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

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
// (Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 2017).
void frameAbout(const glm::vec3& n, glm::vec3& t, glm::vec3& b) {
    const float sign = std::copysign(1.f, n.z);
    const float a = -1.f / (sign + n.z);
    const float c = n.x * n.y * a;
    t = glm::vec3(1.f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    b = glm::vec3(c, sign + n.y * n.y * a, -n.y);
}

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
    EnvTransferStats stats;

    // The scene as rasterised: every part, world space.
    TriangleBvh bvh;
    for (const MeshPart& p : scene.parts) bvh.addMesh(p.positions, p.indices);
    bvh.commit();
    stats.bvhMs = msSince(t0);
    const float radius = scene.bounds.empty() ? 1.f : std::max(scene.bounds.radius(), 1e-6f);
    const float hair = RAY_HAIR * radius, length = RAY_LENGTH * radius;

    // The pattern: M Hammersley points (the first coordinate at the strata's centres).
    const size_t M = size_t(rays);
    std::vector<glm::vec2> pattern(M);
    for (size_t k = 0; k < M; ++k) pattern[k] = glm::vec2((float(k) + 0.5f) / float(M), radicalInverse2(uint32_t(k)));

    std::vector<size_t> covered;
    for (size_t s = 0; s < n; ++s)
        if (b.A[s] > 0.f) covered.push_back(s);
    std::vector<float> transfer(n * ENV_TRANSFER_COEFFICIENTS, 0.f);

    std::atomic<size_t> next{0}, done{0}, traced{0};
    auto work = [&](bool reports) {
        size_t myRays = 0;
        for (;;) {
            const size_t first = next.fetch_add(CHUNK);
            if (first >= covered.size()) break;
            const size_t last = std::min(first + CHUNK, covered.size());
            for (size_t c = first; c < last; ++c) {
                const size_t s = covered[c];
                const glm::vec3 P = b.position(s);
                glm::vec3 N = b.normal(s);
                const float len = glm::length(N);
                N = len > 0.f ? N / len : glm::vec3(0, 1, 0);
                glm::vec3 Ng = hasNg ? glm::vec3(b.Ng[s * 3], b.Ng[s * 3 + 1], b.Ng[s * 3 + 2]) : N;
                const float lenG = glm::length(Ng);
                Ng = lenG > 0.f ? Ng / lenG : N;
                glm::vec3 t, bt;
                frameAbout(N, t, bt);
                // Cranley and Patterson, "Randomization of Number Theoretic Methods for Multiple
                // Integration", SIAM J. Numer. Anal. 1976: one toroidal shift of the whole
                // pattern per sample keeps its stratification and makes neighbouring samples'
                // errors independent (noise, not a pattern repeated across the image).
                const uint64_t h = mix64(uint64_t(s));
                const float du = float(double(h >> 40) * (1.0 / 16777216.0));
                const float dv = float(double((h >> 16) & 0xffffffull) * (1.0 / 16777216.0));
                const glm::vec3 from = P + Ng * hair;
                std::array<float, ENV_TRANSFER_COEFFICIENTS> sum{};
                for (const glm::vec2& q : pattern) {
                    float u = q.x + du, v = q.y + dv;
                    u -= std::floor(u);
                    v -= std::floor(v);
                    // Malley's method: uniform on the disk, lifted to the hemisphere (density
                    // cos / pi); u is r^2, so u = 0 is the pole and u -> 1 the horizon.
                    const float r = std::sqrt(u), phi = 6.2831853071795864f * v;
                    const float z = std::sqrt(std::max(0.f, 1.f - u));
                    const glm::vec3 w = glm::normalize(t * (r * std::cos(phi)) + bt * (r * std::sin(phi)) + N * z);
                    if (glm::dot(Ng, w) <= 0.f) continue; // below its own surface: occluded
                    ++myRays;
                    if (bvh.occluded(from, from + w * length, 1e-6f)) continue;
                    const auto y = lightmath::shEvaluate(lightmath::vec3<float>(w));
                    for (int i = 0; i < ENV_TRANSFER_COEFFICIENTS; ++i) sum[size_t(i)] += y[size_t(i)];
                }
                const float inv = 1.f / float(M);
                for (int i = 0; i < ENV_TRANSFER_COEFFICIENTS; ++i)
                    transfer[s * ENV_TRANSFER_COEFFICIENTS + size_t(i)] = sum[size_t(i)] * inv;
            }
            const size_t d = done.fetch_add(last - first) + (last - first);
            if (reports && progress) progress(d, covered.size());
        }
        traced.fetch_add(myRays);
    };
    unsigned count = threads ? threads : std::max(1u, std::thread::hardware_concurrency());
    count = unsigned(std::min<size_t>(count, std::max<size_t>(1, (covered.size() + CHUNK - 1) / CHUNK)));
    std::vector<std::thread> pool;
    for (unsigned i = 1; i < count; ++i) pool.emplace_back(work, false);
    work(true);
    for (std::thread& th : pool) th.join();
    if (progress) progress(covered.size(), covered.size());

    b.envTransfer = std::move(transfer);
    b.envRays = rays;
    stats.samples = covered.size();
    stats.rays = traced.load();
    stats.threads = count;
    stats.totalMs = msSince(t0);
    return stats;
}

} // namespace dfb
