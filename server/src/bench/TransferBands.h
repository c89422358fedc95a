#pragma once
// dfb-env-bench --transfer-bands: what the environment light's diffuse term with visibility would
// measure if its transfer had more spherical-harmonic bands than the engine's three (issue 19
// point 4: the shadowed diffuse error). The engine's diffuse formula (relight_env.frag,
// docs/lighting.md "Environment light") is evaluated here on the CPU, per sample, at B bands:
//   albedo x (E_open / pi x clamp(sum_i L_i T_i / sum_i L_i T°_i, 0, 1) + sum_k E_k / pi x max(0, N.s_k) V(s_k))
// - E_open: the exact unshadowed irradiance of the map without its suns (engine::extractSuns), from
//   the engine's own 128 x 64 copy (engine::prefilterEnvironment; direct integration instead of
//   the engine's expansion plus residual grid, which equals it);
// - L_i: that map on B bands; T_i and T°_i: the sample's shadowed and unshadowed transfer on the
//   same `rays` cosine-distributed directions (as the bake's, dfb-bake --env-rays);
// - the suns: their irradiance and direction as the engine extracts them, visibility by one ray
//   each (the engine's shadow maps);
// against the brute-force reference (renderEnvironmentReference, multiple importance sampling),
// with EnvFigures.h's figures. It led to the five-band transfer of format version 5; against the
// engine's own diffuse row at five bands it reads lower (FlightHelmet, 1,024 rays: 4.3 / 2.8 %
// against the engine's 4.7 / 4.2 % under sunrise / interior). It differs from the engine in the
// unshadowed transfer (estimated with the same rays as the shadowed one, where the engine takes the
// exact clamped cosine; storing the bake's transfer as the exact one less the occluded part's
// estimate measured no better), the suns' visibility (one ray each, where the engine has shadow
// maps) and precision (doubles, where the file holds halves); which of these makes the gap was
// not measured.

#include "EnvFigures.h"
#include "engine/EnvironmentMap.h"

#include <dfb/bvh/TriangleBvh.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/lightmath/Environment.h>
#include <dfb/lightmath/SphericalHarmonics.h>
#include <dfb/protocol/Rig.h>
#include <dfb/server/Engine.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <thread>
#include <vector>

namespace dfb::bench {

/// A map as the engine lights with it: its suns taken out (engine::extractSuns), and the rest as
/// the engine's own small copy (prefilterEnvironment's, one level), its texels as directions with
/// radiance x solid angle, and its L_i on SH_MAX_BANDS bands.
struct MapWithoutSuns {
    std::vector<engine::EnvSun> suns;
    ImageF small;
    std::vector<glm::dvec3> dirs, weighted, L;
};

inline MapWithoutSuns mapWithoutSuns(ImageF map) {
    namespace lm = lightmath;
    constexpr int K = lm::SH_MAX_BANDS * lm::SH_MAX_BANDS;
    MapWithoutSuns m;
    m.suns = engine::extractSuns(map);
    const engine::EnvLevels levels = engine::prefilterEnvironment(map, 1, ENV_PREFILTER_WIDTH);
    m.small = ImageF{levels.shWidth, levels.shHeight, levels.sh};
    m.L.assign(K, glm::dvec3(0.0));
    double y[K];
    for (int j = 0; j < m.small.height; ++j)
        for (int i = 0; i < m.small.width; ++i) {
            const glm::dvec3 d = lm::envDirection((i + 0.5) / m.small.width, (j + 0.5) / m.small.height);
            const float* t = &m.small.rgba[(size_t(j) * size_t(m.small.width) + size_t(i)) * 4];
            const glm::dvec3 c = glm::dvec3(t[0], t[1], t[2]) * lm::envTexelSolidAngle(j, m.small.width, m.small.height);
            m.dirs.push_back(d);
            m.weighted.push_back(c);
            lm::shEvaluateBands(d, lm::SH_MAX_BANDS, y);
            for (int k = 0; k < K; ++k) m.L[size_t(k)] += c * y[k];
        }
    return m;
}

/// Runs `work` on every hardware thread, this one included, and waits for all.
inline void onEveryCore(const std::function<void()>& work) {
    std::vector<std::thread> pool;
    for (unsigned i = 1; i < std::max(1u, std::thread::hardware_concurrency()); ++i) pool.emplace_back(work);
    work();
    for (std::thread& th : pool) th.join();
}

/// Per pixel (RGBA, alpha 1) the sum of its samples' values radiance[s * count + c]: one image per
/// c < count.
inline std::vector<ImageF> perPixelImages(const DeepBuffer& g, const std::vector<glm::dvec3>& radiance, size_t count) {
    std::vector<ImageF> out;
    for (size_t c = 0; c < count; ++c) {
        ImageF img{g.width, g.height, std::vector<float>(g.pixelCount() * 4, 1.f)};
        for (size_t p = 0; p < g.pixelCount(); ++p) {
            glm::dvec3 sum(0.0);
            for (uint32_t s = g.sampleOffset[p]; s < g.sampleOffset[p + 1]; ++s) sum += radiance[s * count + c];
            for (int k = 0; k < 3; ++k) img.rgba[p * 4 + size_t(k)] = float(sum[k]);
        }
        out.push_back(std::move(img));
    }
    return out;
}

/// Per pixel (the coverage-weighted sum of its samples, RGBA) the diffuse radiance of the Lambert
/// shot `g` (bench::variant "diffuse") under `map` (RGBA float lat-long, unrotated, with its sun)
/// at each of `bandCounts` (each <= SH_MAX_BANDS).
inline std::vector<ImageF> transferBandImages(const DeepBuffer& g, const TriangleBvh& bvh, float radius, ImageF map, int rays,
                                              const std::vector<int>& bandCounts) {
    namespace lm = lightmath;
    constexpr int K = lm::SH_MAX_BANDS * lm::SH_MAX_BANDS;
    const MapWithoutSuns m = mapWithoutSuns(std::move(map));
    const std::vector<engine::EnvSun>& suns = m.suns;
    const std::vector<glm::dvec3>&dirs = m.dirs, &weighted = m.weighted, &L = m.L;
    const size_t n = g.sampleCount(), nb = bandCounts.size();
    std::vector<glm::dvec3> radiance(n * nb, glm::dvec3(0.0));
    std::atomic<size_t> next{0};
    auto work = [&] {
        std::vector<double> T(K), open(K);
        double w[K];
        for (size_t s; (s = next.fetch_add(1)) < n;) {
            if (g.A[s] <= 0.f) continue;
            const glm::dvec3 P(g.position(s));
            const glm::dvec3 N = glm::normalize(glm::dvec3(g.N[s * 3], g.N[s * 3 + 1], g.N[s * 3 + 2]));
            const glm::dvec3 Ng = glm::normalize(glm::dvec3(g.Ng[s * 3], g.Ng[s * 3 + 1], g.Ng[s * 3 + 2]));
            if (!std::isfinite(N.x) || !std::isfinite(Ng.x)) continue;
            const glm::vec3 from = glm::vec3(P + Ng * (1e-5 * double(radius)));
            auto visible = [&](const glm::dvec3& d) {
                return glm::dot(Ng, d) > 0 && !bvh.occluded(from, from + glm::vec3(d) * (4.f * radius), 1e-6f);
            };
            glm::dvec3 openIrradiance(0.0); // E_open / pi
            for (size_t t = 0; t < dirs.size(); ++t) openIrradiance += weighted[t] * std::max(0.0, glm::dot(N, dirs[t]));
            openIrradiance /= lm::ENV_PI;
            const glm::dvec3 t = glm::normalize(glm::cross(N, std::abs(N.y) < 0.9 ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0)));
            const glm::dvec3 b = glm::cross(N, t);
            std::fill(T.begin(), T.end(), 0.0);
            std::fill(open.begin(), open.end(), 0.0);
            // Stratified in the first coordinate, golden-ratio in the second, shifted per sample
            // (Cranley and Patterson 1976, as the bake's).
            const double du = std::fmod(double(s) * 0.7548776662466927, 1.0), dv = std::fmod(double(s) * 0.5698402909980532, 1.0);
            for (int k = 0; k < rays; ++k) {
                const double u = std::fmod((k + 0.5) / rays + du, 1.0), v = std::fmod(k * 0.6180339887498949 + dv, 1.0);
                const double r = std::sqrt(u), phi = 2 * lm::ENV_PI * v, z = std::sqrt(std::max(0.0, 1 - u));
                const glm::dvec3 dir = glm::normalize(t * (r * std::cos(phi)) + b * (r * std::sin(phi)) + N * z);
                lm::shEvaluateBands(dir, lm::SH_MAX_BANDS, w);
                for (int i = 0; i < K; ++i) open[size_t(i)] += w[i];
                if (!visible(dir)) continue;
                for (int i = 0; i < K; ++i) T[size_t(i)] += w[i];
            }
            glm::dvec3 sunPart(0.0);
            for (const engine::EnvSun& sun : suns) {
                const glm::dvec3 s0 = glm::normalize(glm::dvec3(sun.direction));
                if (glm::dot(N, s0) > 0 && visible(s0)) sunPart += glm::dvec3(sun.irradiance) * (glm::dot(N, s0) / lm::ENV_PI);
            }
            const glm::dvec3 albedo(g.albedo[s * 3], g.albedo[s * 3 + 1], g.albedo[s * 3 + 2]);
            for (size_t c = 0; c < nb; ++c) {
                const int count = bandCounts[c] * bandCounts[c];
                glm::dvec3 shadowed(0.0), unshadowed(0.0);
                for (int i = 0; i < count; ++i) shadowed += L[size_t(i)] * T[size_t(i)], unshadowed += L[size_t(i)] * open[size_t(i)];
                const glm::dvec3 ratio = glm::clamp(shadowed / glm::max(unshadowed, glm::dvec3(1e-12)), 0.0, 1.0);
                radiance[s * nb + c] = double(g.A[s]) * albedo * (openIrradiance * ratio + sunPart);
            }
        }
    };
    onEveryCore(work);
    return perPixelImages(g, radiance, nb);
}

} // namespace dfb::bench
