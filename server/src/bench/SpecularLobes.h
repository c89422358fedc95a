#pragma once
// dfb-env-bench --specular-lobes: what the environment light's specular term would measure if each
// sample held its visible GGX lobe as K sub-lobes instead of one (issue 19 point 4: the tabletop's
// specular error). The view is fixed, so a sample's lobe f(l, v) N.l V(l) is too; the bake's rays
// (GGX-distributed directions, weights lightmath::ggxLobeWeight, the visible ones) are grouped
// into K clusters by direction (weighted spherical k-means, Lloyd's iterations), and each is read
// from the engine's prefiltered map towards its weighted mean direction at the prefiltered level
// whose kernel has the cluster's mean resultant length:
//   specular = meanFresnel x sum_k W_k prefiltered(d_k, r(R_k)) + sum_j E_j f(s_j, v) N.s_j V(s_j)
// (W_k: the cluster's share of the lobe's weight; R_k = |sum w l| / sum w;
// lightmath::prefilterRoughnessForResultant). One isotropic read
// cannot hold a grazing lobe's peak near the mirror direction and its long tail towards the
// horizon at once (docs/operations.md, the lobe table of 2026-12-06); K reads can. Evaluated on
// the CPU for the metal shot (bench::variant "specular"), the map's suns exact (one ray each).
// It chose the three polar rings of format version 7 (DeepBuffer::envRings; docs/operations.md).

#include "LobeRays.h"
#include "TransferBands.h"
#include "engine/EnvironmentMap.h"

#include <dfb/bvh/TriangleBvh.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/lightmath/Brdf.h>
#include <dfb/lightmath/Environment.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <vector>

namespace dfb::bench {

/// The engine's prefiltered map on the CPU in its lat-long layout (the engine reads the same levels
/// as a cube map; the two agree to about 1 %: PrefilteredCubeMapAgreesWithTheLatLongLevels):
/// bilinear in each level, linear between levels at lod = roughness x (levels - 1).
struct CpuPrefiltered {
    engine::EnvLevels levels;
    glm::dvec3 texel(int k, int i, int j) const {
        const int w = levels.widths[size_t(k)], h = w / 2;
        i = ((i % w) + w) % w;
        j = std::clamp(j, 0, h - 1);
        const float* t = &levels.rgba[size_t(k)][(size_t(j) * size_t(w) + size_t(i)) * 4];
        return {t[0], t[1], t[2]};
    }
    glm::dvec3 bilinear(int k, const glm::dvec2& uv) const {
        const int w = levels.widths[size_t(k)], h = w / 2;
        const double x = uv.x * w - 0.5, y = uv.y * h - 0.5;
        const int i = int(std::floor(x)), j = int(std::floor(y));
        const double fx = x - i, fy = y - j;
        return (texel(k, i, j) * (1 - fx) + texel(k, i + 1, j) * fx) * (1 - fy) +
               (texel(k, i, j + 1) * (1 - fx) + texel(k, i + 1, j + 1) * fx) * fy;
    }
    glm::dvec3 operator()(const glm::dvec3& d, double roughness) const {
        const glm::dvec2 uv = lightmath::envLatLong(d);
        const int last = int(levels.widths.size()) - 1;
        const double lod = std::clamp(roughness, 0.0, 1.0) * last;
        const int k0 = std::min(int(lod), last), k1 = std::min(k0 + 1, last);
        const double f = lod - k0;
        return bilinear(k0, uv) * (1 - f) + bilinear(k1, uv) * f;
    }
};

/// Per pixel (RGBA) the metal shot `g`'s specular radiance under `map` (unrotated, with its suns)
/// for each grouping of `groupings`, then one image with a single read towards the visible part's
/// mean direction at the sample's own roughness (the engine's formula on these rays, without the
/// rings). A grouping K > 0 is k-means of the rays into K clusters; -(100 A + 10 P + K) is the
/// sampling domain's A azimuth x P polar bins (of ggxHalfVector's xi.x, xi.y after the sample's
/// shift) clustered into K, so -(100 + 11 P) is P polar rings (lightmath::lobeRing at P = 3).
inline std::vector<ImageF> specularLobeImages(const DeepBuffer& g, const TriangleBvh& bvh, float radius, ImageF map, int rays,
                                              const std::vector<int>& groupings, bool shadowed) {
    namespace lm = lightmath;
    CpuPrefiltered pre;
    const std::vector<engine::EnvSun> suns = engine::extractSuns(map);
    pre.levels = engine::prefilterEnvironment(map, 6, ENV_PREFILTER_WIDTH);
    const size_t n = g.sampleCount(), nb = groupings.size() + 1;
    std::vector<glm::dvec3> radiance(n * nb, glm::dvec3(0.0));
    const glm::dvec3 eye(g.camera.position());
    std::atomic<size_t> next{0};
    auto work = [&] {
        std::vector<glm::dvec3> dirs;
        std::vector<double> weights;
        std::vector<double> binU, binV;
        LobeSample x;
        x.bvh = &bvh, x.radius = radius, x.shadowed = shadowed;
        for (size_t s; (s = next.fetch_add(1)) < n;) {
            if (!x.set(g, s, eye)) continue;
            dirs.clear();
            weights.clear();
            binU.clear();
            binV.clear();
            glm::dvec3 fresnelSum(0.0);
            double weightSum = 0;
            x.forEachRay(s, rays, [&](const glm::dvec3& l, double weight, double VdotH, double u, double v) {
                weight /= double(rays);
                weightSum += weight;
                fresnelSum += weight * lm::fresnelSchlick(x.f0, 1.0, VdotH);
                if (!x.visible(l)) return;
                dirs.push_back(l);
                weights.push_back(weight);
                binU.push_back(u);
                binV.push_back(v);
            });
            const glm::dvec3 sunPart = x.sunsSpecular(suns);
            const glm::dvec3 meanFresnel = weightSum > 0 ? fresnelSum / weightSum : glm::dvec3(0.0);
            const size_t m = dirs.size();
            glm::dvec3 all(0.0);
            double visibleWeight = 0;
            for (size_t j = 0; j < m; ++j) all += weights[j] * dirs[j], visibleWeight += weights[j];
            // The engine's formula on these rays: one read, the visible mean direction, the sample's roughness.
            if (visibleWeight > 0)
                radiance[s * nb + nb - 1] = double(g.A[s]) * (meanFresnel * visibleWeight * pre(glm::normalize(all), x.roughness) + sunPart);
            else
                radiance[s * nb + nb - 1] = double(g.A[s]) * sunPart;
            // Items: the rays themselves, or the sums of the rays of fixed bins of the sampling domain.
            auto clustered = [&](const std::vector<double>& iw, const std::vector<glm::dvec3>& im, int wanted) {
                glm::dvec3 sum(0.0);
                std::vector<size_t> items;
                for (size_t j = 0; j < iw.size(); ++j)
                    if (iw[j] > 0) items.push_back(j);
                if (items.empty()) return sum;
                const int K = std::min<int>(wanted, int(items.size()));
                std::vector<glm::dvec3> centre{glm::normalize(all)};
                while (int(centre.size()) < K) {
                    size_t best = 0;
                    double bestScore = -1;
                    for (size_t j : items) {
                        double nearest = -2;
                        const glm::dvec3 d = glm::normalize(im[j]);
                        for (const glm::dvec3& q : centre) nearest = std::max(nearest, glm::dot(q, d));
                        const double score = iw[j] * (1 - nearest);
                        if (score > bestScore) bestScore = score, best = j;
                    }
                    centre.push_back(glm::normalize(im[best]));
                }
                std::vector<glm::dvec3> moment(static_cast<size_t>(K));
                std::vector<double> W(static_cast<size_t>(K));
                for (int it = 0; it < 8; ++it) {
                    std::fill(moment.begin(), moment.end(), glm::dvec3(0.0));
                    std::fill(W.begin(), W.end(), 0.0);
                    for (size_t j : items) {
                        int best = 0;
                        for (int q = 1; q < K; ++q)
                            if (glm::dot(centre[size_t(q)], im[j]) > glm::dot(centre[size_t(best)], im[j])) best = q;
                        moment[size_t(best)] += im[j];
                        W[size_t(best)] += iw[j];
                    }
                    for (int q = 0; q < K; ++q)
                        if (W[size_t(q)] > 0) centre[size_t(q)] = glm::normalize(moment[size_t(q)]);
                }
                for (int q = 0; q < K; ++q) {
                    if (W[size_t(q)] <= 0) continue;
                    const double R = glm::length(moment[size_t(q)]) / W[size_t(q)];
                    sum += W[size_t(q)] * pre(centre[size_t(q)], lm::prefilterRoughnessForResultant(R));
                }
                return sum;
            };
            std::vector<double> rw(weights);
            std::vector<glm::dvec3> rm(m);
            for (size_t j = 0; j < m; ++j) rm[j] = weights[j] * dirs[j];
            for (size_t c = 0; c + 1 < nb; ++c) {
                glm::dvec3 sum(0.0);
                const int want = groupings[c];
                if (want > 0) {
                    sum = clustered(rw, rm, want);
                } else {
                    // -want = 100 a + 10 p + K: a azimuth bins x p polar bins, clustered into K.
                    const int A = -want / 100, Pn = (-want / 10) % 10, K = -want % 10;
                    std::vector<double> bw(size_t(A * Pn), 0.0);
                    std::vector<glm::dvec3> bm(size_t(A * Pn), glm::dvec3(0.0));
                    for (size_t j = 0; j < m; ++j) {
                        const int bin = std::min(int(binU[j] * A), A - 1) + A * std::min(int(binV[j] * Pn), Pn - 1);
                        bw[size_t(bin)] += weights[j];
                        bm[size_t(bin)] += weights[j] * dirs[j];
                    }
                    sum = clustered(bw, bm, K);
                }
                radiance[s * nb + c] = double(g.A[s]) * (meanFresnel * sum + sunPart);
            }
        }
    };
    onEveryCore(work);
    return perPixelImages(g, radiance, nb);
}

} // namespace dfb::bench
