#pragma once
// The near-field horizon of each G-buffer sample (DeepBuffer::horizon; the math of
// dfb/lightmath/Horizon.h), traced against the scene the bake rasterised. The bake computes it
// itself at each pass's surface points (BakeOptions::horizonRadius); bakeHorizon gives one to a
// buffer that has none (a shot read from a file, a hand-made buffer) from its stored samples.

#include <dfb/core/Result.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/gbuffer/Scene.h>

#include <cstddef>

namespace dfb {

/// What one horizon bake did.
struct HorizonStats {
    size_t samples = 0;   ///< covered samples (A > 0) given a horizon
    size_t rays = 0;      ///< rays traced
    unsigned threads = 0; ///< worker threads used
    double totalMs = 0.0; ///< the whole call (building the hierarchy included), milliseconds
};

/// Largest near-field radius a bake accepts, as a fraction of the scene's bounding radius: a
/// horizon is a height field's description of what lies around a point, which a reach of a
/// sizeable part of the scene no longer is (it would close the sky above a floor under a table).
constexpr float MAX_HORIZON_RADIUS_FRACTION = 0.25f;

/// Fills `buffer.horizon` (HORIZON_AZIMUTHS floats per sample) and `buffer.horizonRadius` =
/// `radiusFraction` x the scene's bounding radius. Per covered sample (A > 0) and azimuth k
/// (lightmath::horizonDirection about the geometric normal as stored in half floats): the sine of
/// the lowest elevation at which a ray from P + Ng x (1e-5 x scene radius) over horizonRadius
/// meets none of the scene's triangles, found by stepping the sine by 1/8 from 0 and halving the
/// step where it opens five times (to 1/256). The lowest open elevation, not the highest closed
/// one: under an overhang the horizon stays low, so the light it lets through is shadowed by the
/// map, never shadowed here when open. A merged sample's averaged position may lie inside a
/// mesh (a curved surface, or the corner of two faces its points fell on): while the ray along
/// the normal meets the back of a triangle within the reach (up to four times), the rays start
/// just past it instead. Uncovered samples get zeros.
///
/// Threading: runs `threads` workers (0 = std::thread::hardware_concurrency()), the caller being
/// one of them. Fails with InvalidValue, leaving the buffer unchanged, when `radiusFraction` is
/// not in (0, MAX_HORIZON_RADIUS_FRACTION] or the buffer's layers are inconsistent.
Result<HorizonStats> bakeHorizon(const Scene& scene, DeepBuffer& buffer, float radiusFraction, unsigned threads = 0);

} // namespace dfb
