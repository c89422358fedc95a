#pragma once
// dfb-env-bench --specular-bands: what the environment light's specular term would measure if
// each sample held a baked specular transfer (issue 19 point 4: the tabletop's specular error).
// The view is fixed, so a sample's GGX lobe is too, and its reflection of a map L is the linear
// function sum_i L_i S_i of the map's spherical harmonics, with
//   S_i = integral f(l, v) N.l V(l) Y_i(l) dl
// (the glossy transfer of Sloan, Kautz and Snyder, "Precomputed Radiance Transfer for Real-Time
// Rendering in Dynamic, Low-Frequency Lighting Environments", 2002, section 6, whose transfer
// matrix becomes a vector for one view). Evaluated here on the CPU for the metal shot
// (bench::variant "specular": F0 = albedo, F90 = 1) at B bands:
//   specular = sum_i L_i S_i + sum_k E_k f(s_k, v) N.s_k V(s_k)
// - L_i: the map without its suns (engine::extractSuns), from the engine's own 128 x 64 copy;
// - S_i: `rays` GGX-distributed directions per sample (ggxHalfVector, weights ggxLobeWeight times
//   the Fresnel factor), traced against the scene; "open" leaves V out on both sides;
// - the suns: exact, visibility by one ray each (the engine's shadow maps);
// plus a row "direct": the same rays' own estimate of the integral against the small map (no
// expansion), which bounds what any number of bands could reach with these rays.

#include "LobeRays.h"
#include "TransferBands.h"
#include "engine/EnvironmentMap.h"

#include <dfb/bvh/TriangleBvh.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/lightmath/Brdf.h>
#include <dfb/lightmath/Environment.h>
#include <dfb/lightmath/SphericalHarmonics.h>
#include <dfb/protocol/Rig.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <thread>
#include <vector>

namespace dfb::bench {

/// Per pixel (RGBA) the metal shot `g`'s specular radiance under `map` (unrotated, with its suns)
/// with a specular transfer of each of `bandCounts` (RGB, the Fresnel factor per direction), then
/// the rays' direct estimate, then with a scalar transfer per sample times the lobe's mean Fresnel
/// factor at each of `bandCounts`.
/// `shadowed`: the transfer and the suns traced against the scene.
inline std::vector<ImageF> specularBandImages(const DeepBuffer& g, const TriangleBvh& bvh, float radius, ImageF map, int rays,
                                              const std::vector<int>& bandCounts, bool shadowed) {
    namespace lm = lightmath;
    constexpr int K = lm::SH_MAX_BANDS * lm::SH_MAX_BANDS;
    const MapWithoutSuns m = mapWithoutSuns(std::move(map));
    const std::vector<engine::EnvSun>& suns = m.suns;
    const ImageF& small = m.small;
    const std::vector<glm::dvec3>& L = m.L;
    auto smallAt = [&](const glm::dvec3& d) {
        const glm::dvec2 uv = lm::envLatLong(d);
        const int i = std::clamp(int(uv.x * small.width), 0, small.width - 1), j = std::clamp(int(uv.y * small.height), 0, small.height - 1);
        const float* t = &small.rgba[(size_t(j) * size_t(small.width) + size_t(i)) * 4];
        return glm::dvec3(t[0], t[1], t[2]);
    };
    const size_t n = g.sampleCount(), nb = 2 * bandCounts.size() + 1;
    std::vector<glm::dvec3> radiance(n * nb, glm::dvec3(0.0));
    const glm::dvec3 eye(g.camera.position());
    std::atomic<size_t> next{0};
    auto work = [&] {
        std::vector<glm::dvec3> S(K);
        std::vector<double> Sw(K); // without the Fresnel factor: the scalar transfer
        double w[K];
        LobeSample x;
        x.bvh = &bvh, x.radius = radius, x.shadowed = shadowed;
        for (size_t s; (s = next.fetch_add(1)) < n;) {
            if (!x.set(g, s, eye)) continue;
            std::fill(S.begin(), S.end(), glm::dvec3(0.0));
            std::fill(Sw.begin(), Sw.end(), 0.0);
            glm::dvec3 direct(0.0), fresnelSum(0.0);
            double weightSum = 0;
            x.forEachRay(s, rays, [&](const glm::dvec3& l, double weight, double VdotH, double, double) {
                const glm::dvec3 f = weight * lm::fresnelSchlick(x.f0, 1.0, VdotH) / double(rays);
                weightSum += weight / double(rays);
                fresnelSum += f;
                if (!x.visible(l)) return;
                lm::shEvaluateBands(l, lm::SH_MAX_BANDS, w);
                for (int i = 0; i < K; ++i) S[size_t(i)] += f * w[i], Sw[size_t(i)] += weight / double(rays) * w[i];
                direct += f * smallAt(l);
            });
            const glm::dvec3 sunPart = x.sunsSpecular(suns);
            // One scalar transfer per sample: the Fresnel factor as the lobe's mean, (F0 A + F90 B) /
            // (A + B) of the split sum, outside the integral.
            const glm::dvec3 meanFresnel = weightSum > 0 ? fresnelSum / weightSum : glm::dvec3(0.0);
            const size_t nbands = bandCounts.size();
            for (size_t c = 0; c < nbands; ++c) {
                glm::dvec3 sum(0.0), scalar(0.0);
                for (int i = 0; i < bandCounts[c] * bandCounts[c]; ++i) sum += L[size_t(i)] * S[size_t(i)], scalar += L[size_t(i)] * Sw[size_t(i)];
                radiance[s * nb + c] = double(g.A[s]) * (glm::max(sum, glm::dvec3(0.0)) + sunPart);
                radiance[s * nb + nbands + 1 + c] = double(g.A[s]) * (glm::max(scalar * meanFresnel, glm::dvec3(0.0)) + sunPart);
            }
            radiance[s * nb + nbands] = double(g.A[s]) * (direct + sunPart);
        }
    };
    onEveryCore(work);
    return perPixelImages(g, radiance, nb);
}

} // namespace dfb::bench
