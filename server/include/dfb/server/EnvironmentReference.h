#pragma once
// The environment light's brute-force reference (issue 19 point 4; docs/lighting.md,
// "Environment light"): per G-buffer sample, many rays into the map with Embree visibility and the
// layered BRDF the relight shaders evaluate for punctual lights (lightmath/Brdf.h), against which
// the fast path (order-3 spherical harmonics with the baked transfer, the split sum) is measured.
// CPU only, seconds per frame: for benchmarks, tests and offline checks.

#include <dfb/core/Result.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/protocol/Rig.h>
#include <dfb/server/Engine.h>
#include <dfb/bvh/TriangleBvh.h>

#include <string>

namespace dfb {

/// Radiance of environment light `l` (colour x intensity included) per pixel, the coverage-
/// weighted sum over its samples (as Engine::renderLightLinear), RGBA with A = 1.
/// Per sample `rays` directions, each drawn from one of three strategies in turn and weighted by
/// their mixture's density (the balance heuristic of one-sample multiple importance sampling;
/// Veach and Guibas, "Optimally Combining Sampling Techniques for Monte Carlo Rendering",
/// SIGGRAPH 1995): the map's texels by luminance x sin(theta), the cosine about N, and GGX half
/// vectors of the sample's roughness (Walter et al. 2007). The map is read texel-constant at its
/// full resolution (a constant colour when l.envMap is empty). When l.shadow and `scene` is given,
/// a ray from P + 1e-5 radius Ng that hits `scene` within 4 radius (or leaves below the
/// geometric plane) sees nothing; otherwise every direction sees the map.
/// Deterministic (per-sample seeds), on every hardware thread.
Result<ImageF> renderEnvironmentReference(const DeepBuffer& g, const TriangleBvh* scene, float sceneRadius, const Light& l,
                                          const std::string& assetDir, int rays);

} // namespace dfb
