#pragma once
// The environment light's per-sample diffuse shadowed transfer (precomputed radiance transfer:
// Sloan, Kautz and Snyder, "Precomputed Radiance Transfer for Real-Time Rendering in Dynamic,
// Low-Frequency Lighting Environments", SIGGRAPH 2002, section 4), estimated by ray casting
// against the scene the bake rasterised. DeepBuffer::envTransfer says what is stored; the basis
// and the transfer's definition are dfb/lightmath/SphericalHarmonics.h's. The bake computes it
// itself (BakeOptions::envRays); bakeEnvTransfer gives one to a buffer that has none (a shot read
// from a file, a hand-made buffer), with the same estimator.

#include <dfb/core/Result.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/gbuffer/Scene.h>

#include <cstddef>
#include <functional>

namespace dfb {

/// What one transfer bake did (bakeEnvTransfer, or the bake's share: BakeOptions::envStats).
struct EnvTransferStats {
    size_t samples = 0;     ///< covered samples (A > 0) given a transfer
    size_t rays = 0;        ///< rays traced (directions below the geometric plane are not)
    unsigned threads = 0;   ///< worker threads used
    double bvhMs = 0.0;     ///< building the ray-casting hierarchy, milliseconds
    double totalMs = 0.0;   ///< the whole call (hierarchy included), milliseconds
};

/// Fills `buffer.envTransfer` (25 floats per sample: five bands, `buffer.envBands` = 5),
/// `buffer.envLobe` (3; the specular lobe as the buffer's camera sees each sample, DeepBuffer::envLobe, with `rays` GGX directions of its
/// roughness) and `buffer.envRays` = `rays`: for every
/// sample with A > 0, T_i = (1/rays) sum_k V(w_k) Y_i(w_k) over `rays` directions w_k
/// distributed with density max(0, N.w) / pi about the sample's shading normal N (so that the
/// estimate of (1/pi) integral V max(0, N.w) Y_i dw needs no weights). The directions are one
/// fixed Hammersley pattern, shifted per sample (Cranley-Patterson rotation) by a hash of the
/// sample index: a bake is reproducible, whatever the thread count. V(w) = 0 for directions at or
/// below the sample's geometric plane (dot(Ng, w) <= 0: its own surface), else 1 when the ray from
/// P + Ng x (1e-5 x scene radius) over 4 scene radii meets none of the scene's triangles (every
/// part, as rasterised; alpha-masked and blended materials occlude fully). Uncovered samples get
/// zeros.
///
/// Each stored sample is taken as one surface point: right for flat (1 sample per pixel) buffers,
/// approximate for merged samples of a multi-sample bake, whose averaged position may lie inside
/// a curved mesh (its rays then start occluded); the bake itself traces each pass's points.
///
/// Threading: runs `threads` workers (0 = std::thread::hardware_concurrency()), the caller being
/// one of them; `progress(done, total)` is called on the calling thread only, may be empty.
/// Fails with InvalidValue, leaving the buffer unchanged, when `rays` is outside
/// [1, MAX_ENV_RAYS] or the buffer's layers are inconsistent.
Result<EnvTransferStats> bakeEnvTransfer(const Scene& scene, DeepBuffer& buffer, int rays, unsigned threads = 0,
                                         const std::function<void(size_t, size_t)>& progress = {});

} // namespace dfb
