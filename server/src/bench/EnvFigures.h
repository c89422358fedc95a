#pragma once
// The environment light's error figures against its ray-traced reference (dfb-env-bench, and the
// test that holds the specular occlusion to them: tests/gpu/env_tabletop_test.cpp): per covered
// pixel the luminance's relative error (pixels under 1e-3 of the mean reference left out), its
// mean and 95th percentile, and the aggregate sum |fast - ref| / sum ref; and the shot with its
// materials made Lambert ("diffuse"), a metal ("specular") or left "baked".

#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/server/Engine.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace dfb::bench {

inline double luminance(const ImageF& img, size_t p) {
    return 0.2126 * img.rgba[p * 4] + 0.7152 * img.rgba[p * 4 + 1] + 0.0722 * img.rgba[p * 4 + 2];
}

// The reference luminance under which a pixel's relative error is left out: 1e-3 of the mean over
// the covered pixels.
inline double luminanceFloor(const ImageF& ref, const DeepBuffer& g) {
    double sumRef = 0;
    size_t covered = 0;
    for (size_t p = 0; p < g.pixelCount(); ++p)
        if (g.sampleOffset[p + 1] > g.sampleOffset[p]) sumRef += luminance(ref, p), ++covered;
    return 1e-3 * sumRef / double(std::max<size_t>(covered, 1));
}

struct Figures {
    double mean = 0, p95 = 0, aggregate = 0;
    size_t pixels = 0;
};

inline Figures compare(const ImageF& fast, const ImageF& ref, const DeepBuffer& g) {
    const double floor = luminanceFloor(ref, g);
    std::vector<double> rel;
    double sumAbs = 0, sumR = 0;
    for (size_t p = 0; p < g.pixelCount(); ++p) {
        if (g.sampleOffset[p + 1] == g.sampleOffset[p]) continue;
        const double r = luminance(ref, p), f = luminance(fast, p);
        sumAbs += std::abs(f - r);
        sumR += r;
        if (r > floor) rel.push_back(std::abs(f - r) / r);
    }
    Figures out;
    out.pixels = rel.size();
    if (rel.empty()) return out;
    for (double x : rel) out.mean += x;
    out.mean /= double(rel.size());
    std::sort(rel.begin(), rel.end());
    out.p95 = rel[std::min(rel.size() - 1, size_t(0.95 * double(rel.size())))];
    out.aggregate = sumR > 0 ? sumAbs / sumR : 0;
    return out;
}

/// Per-pixel relative errors (pixels whose reference luminance is over 1e-3 of the mean) in cells
/// by quarter of N.v (first index) and of roughness (second), from each pixel's first sample.
struct QuarterBins {
    struct Cell {
        double absolute = 0, signedSum = 0;
        size_t pixels = 0;
    } cell[4][4];
};

inline QuarterBins binByViewAndRoughness(const ImageF& fast, const ImageF& ref, const DeepBuffer& g) {
    const double floor = luminanceFloor(ref, g);
    const glm::vec3 eye = g.camera.position();
    QuarterBins out;
    for (size_t p = 0; p < g.pixelCount(); ++p) {
        if (g.sampleOffset[p + 1] == g.sampleOffset[p]) continue;
        const double r = luminance(ref, p), f = luminance(fast, p);
        if (r <= floor) continue;
        const size_t s = g.sampleOffset[p];
        const glm::vec3 N = glm::normalize(glm::vec3(g.N[s * 3], g.N[s * 3 + 1], g.N[s * 3 + 2]));
        const glm::vec3 V = g.camera.orthographic ? -g.camera.forward() : glm::normalize(eye - g.position(s));
        const auto quarter = [](float x) { return std::clamp(int(4.f * x), 0, 3); };
        auto& c = out.cell[quarter(glm::dot(N, V))][quarter(g.brdf[s * 4 + 1])];
        c.absolute += std::abs(f - r) / r;
        c.signedSum += (f - r) / r;
        ++c.pixels;
    }
    return out;
}

// The shot with its materials changed: "diffuse" (Lambert), "specular" (a metal) or as baked.
inline DeepBuffer variant(const DeepBuffer& g, const std::string& kind) {
    DeepBuffer v = g;
    if (kind == "baked") return v;
    for (size_t s = 0; s < v.A.size(); ++s) {
        v.brdf[s * 4] = kind == "specular" ? 1.f : 0.f; // metallic
        if (kind == "diffuse") v.brdf[s * 4 + 2] = 0.f;  // specular level 0: Lambert
        for (int c = 0; c < 4; ++c) v.sheen[s * 4 + size_t(c)] = 0.f;
        v.coat[s * 2] = 0.f;
    }
    return v;
}

} // namespace dfb::bench
