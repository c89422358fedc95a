#pragma once
// The environment transfer's estimator at one surface point, shared by the bake (each raster
// pass's exact surface points, gbuffer/src/Baker.cpp) and bakeEnvTransfer (a buffer's stored
// samples), and the worker threads both run it on. Private to dfb_gbuffer.

#include <dfb/bvh/TriangleBvh.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/gbuffer/Scene.h>

#include <glm/glm.hpp>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

namespace dfb {

/// The ray-casting hierarchy of every part of `scene` (world space, as rasterised), shared by the
/// bake's tracers (environment transfer, near-field horizon) so that it is built once.
std::shared_ptr<const TriangleBvh> sceneBvh(const Scene& scene);

/// Rays against every triangle of a scene and one fixed pattern of directions. Threading: built on
/// one thread; estimate() is const and may run on any number of threads at once.
class EnvTracer {
public:
    /// Casts against `bvh` (sceneBvh of `scene`; built here when null) with a pattern of
    /// `patternRays` >= 1 directions.
    EnvTracer(const Scene& scene, int patternRays, std::shared_ptr<const TriangleBvh> bvh = nullptr);

    /// The transfer at the surface point P (shading normal N, geometric normal Ng; both are
    /// normalised here): out[i] = (1/m) sum_k V(w_k) Y_i(w_k) over the m pattern directions
    /// k = first, first + stride, ... (first < stride), mapped to the cosine lobe about N and
    /// shifted by a hash of `seed` (docs/gbuffer-format.md, "Environment transfer"). Every
    /// direction of a shifted pattern is distributed as the lobe, so any such subset is an
    /// unbiased estimate, and the subsets first = 0 .. stride - 1 together are the whole pattern.
    /// Returns the rays traced.
    size_t estimate(const glm::vec3& P, const glm::vec3& N, const glm::vec3& Ng, uint64_t seed, size_t first,
                    size_t stride, float out[ENV_TRANSFER_COEFFICIENTS]) const;

    /// Sums over the sample's GGX specular lobe seen along `view` (unit, from the point towards the
    /// camera; `roughness` as the G-buffer's), the same pattern's directions k = first, first +
    /// stride, ... mapped through lightmath::ggxHalfVector and shifted by another hash of `seed`:
    /// out[0] = sum of the weights w (lightmath::ggxLobeWeight), out[1] = that of the visible ones
    /// (V as estimate()'s), out[2..4] = the visible ones' sum of w l; then per ring r
    /// (lightmath::lobeRing of the shifted polar coordinate) at 5 + 4r its visible ones' sum of w
    /// and of w l. Sums of several calls (a merged sample's points) add; encodeLobe and
    /// encodeRings turn them into DeepBuffer::envLobe's and envRings' values.
    /// Returns the rays traced.
    static constexpr int LOBE_SUMS = 5 + 4 * ENV_LOBE_RINGS;
    size_t lobe(const glm::vec3& P, const glm::vec3& N, const glm::vec3& Ng, const glm::vec3& view, float roughness,
                uint64_t seed, size_t first, size_t stride, double out[LOBE_SUMS]) const;
    /// DeepBuffer::envLobe's three values from lobe()'s sums: the visible mean direction,
    /// octahedral-encoded (the mirror direction of V about N where none is visible), and the
    /// visible share (1 where the lobe has no weight above the surface).
    static void encodeLobe(const double sums[LOBE_SUMS], const glm::vec3& N, const glm::vec3& V, float out[ENV_LOBE_COMPONENTS]);
    /// DeepBuffer::envRings' values from lobe()'s sums: per ring its visible mean direction
    /// (octahedral; the mirror direction where none is visible), its visible weight over the whole
    /// lobe's (0 where the lobe has no weight above the surface) and the prefiltered roughness as
    /// wide as it (lightmath::prefilterRoughnessForResultant).
    static void encodeRings(const double sums[LOBE_SUMS], const glm::vec3& N, const glm::vec3& V, float out[ENV_RING_COMPONENTS]);

    int patternRays() const { return int(mPattern.size()); }
    double bvhMs() const { return mBvhMs; } ///< building the hierarchy (0 when given), milliseconds
    const std::shared_ptr<const TriangleBvh>& bvh() const { return mBvh; }

private:
    std::shared_ptr<const TriangleBvh> mBvh;
    std::vector<glm::vec2> mPattern; // Hammersley points in [0, 1)^2
    float mHair = 0.f, mLength = 0.f;
    double mBvhMs = 0.0;
};

/// Calls fn(begin, end) over consecutive chunks of [0, count) on `threads` workers
/// (0 = std::thread::hardware_concurrency()), the calling thread being one of them, and
/// progress(done, count) on the calling thread after each of its chunks (may be empty). Returns
/// the workers used.
unsigned parallelChunks(size_t count, unsigned threads, const std::function<void(size_t, size_t)>& fn,
                        const std::function<void(size_t, size_t)>& progress = {});

} // namespace dfb
