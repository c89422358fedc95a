#include "EnvironmentMap.h"

#include "WorkerPool.h"

#include <dfb/lightmath/Environment.h>

#include <algorithm>
#include <cmath>

namespace dfb::engine {

namespace {

struct LatLong {
    int w = 0, h = 0;
    std::vector<glm::vec3> c;

    // Wraps across the seam (u), clamps at the poles (v).
    glm::vec3 texel(int i, int j) const {
        i = ((i % w) + w) % w;
        j = std::clamp(j, 0, h - 1);
        return c[size_t(j) * size_t(w) + size_t(i)];
    }
    glm::vec3 bilinear(double u, double v) const {
        const double x = u * w - 0.5, y = v * h - 0.5;
        const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
        const float fx = float(x - x0), fy = float(y - y0);
        return glm::mix(glm::mix(texel(x0, y0), texel(x0 + 1, y0), fx), glm::mix(texel(x0, y0 + 1), texel(x0 + 1, y0 + 1), fx), fy);
    }
};

// src resampled to w x h: the average of the source texels each target texel covers when
// shrinking, bilinear when growing.
LatLong resample(const ImageF& src, int w, int h) {
    LatLong out{w, h, std::vector<glm::vec3>(size_t(w) * size_t(h))};
    LatLong in{src.width, src.height, std::vector<glm::vec3>(size_t(src.width) * size_t(src.height))};
    for (size_t p = 0; p < in.c.size(); ++p) in.c[p] = glm::vec3(src.rgba[p * 4], src.rgba[p * 4 + 1], src.rgba[p * 4 + 2]);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            glm::vec3 sum(0.f);
            if (src.width >= w && src.height >= h) {
                const int x0 = int(int64_t(i) * src.width / w), x1 = std::max(x0 + 1, int(int64_t(i + 1) * src.width / w));
                const int y0 = int(int64_t(j) * src.height / h), y1 = std::max(y0 + 1, int(int64_t(j + 1) * src.height / h));
                for (int y = y0; y < y1; ++y)
                    for (int x = x0; x < x1; ++x) sum += in.texel(x, y);
                sum /= float((x1 - x0) * (y1 - y0));
            } else {
                sum = in.bilinear((i + 0.5) / w, (j + 0.5) / h);
            }
            out.c[size_t(j) * size_t(w) + size_t(i)] = sum;
        }
    return out;
}

LatLong halve(const LatLong& a) {
    LatLong out{std::max(a.w / 2, 1), std::max(a.h / 2, 1), {}};
    out.c.resize(size_t(out.w) * size_t(out.h));
    for (int j = 0; j < out.h; ++j)
        for (int i = 0; i < out.w; ++i)
            out.c[size_t(j) * size_t(out.w) + size_t(i)] =
                0.25f * (a.texel(2 * i, 2 * j) + a.texel(2 * i + 1, 2 * j) + a.texel(2 * i, 2 * j + 1) + a.texel(2 * i + 1, 2 * j + 1));
    return out;
}

std::vector<float> toRgba(const LatLong& l) {
    std::vector<float> out(l.c.size() * 4);
    for (size_t p = 0; p < l.c.size(); ++p) {
        out[p * 4] = l.c[p].x;
        out[p * 4 + 1] = l.c[p].y;
        out[p * 4 + 2] = l.c[p].z;
        out[p * 4 + 3] = 1.f;
    }
    return out;
}

// The pyramid's radiance towards unit d at fractional level lod.
glm::vec3 sampleAt(const std::vector<LatLong>& pyramid, const glm::dvec3& d, double lod) {
    lod = std::clamp(lod, 0.0, double(pyramid.size() - 1));
    const int l0 = int(lod), l1 = std::min(l0 + 1, int(pyramid.size()) - 1);
    const glm::dvec2 uv = lightmath::envLatLong(d);
    return glm::mix(pyramid[size_t(l0)].bilinear(uv.x, uv.y), pyramid[size_t(l1)].bilinear(uv.x, uv.y), float(lod - l0));
}

constexpr int PREFILTER_SAMPLES = 64;

// The pyramid averaged over the GGX lobe of `alpha` about N with N = v = r: PREFILTER_SAMPLES
// importance samples, each read at the lod of its solid angle (Colbert and Krivanek 2007).
glm::vec3 prefilteredAt(const std::vector<LatLong>& pyramid, const glm::dvec3& N, double alpha, double texelSolidAngle) {
    // Any orthonormal frame about N (the lobe is symmetric about N).
    const glm::dvec3 up = std::abs(N.y) < 0.999 ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0);
    const glm::dvec3 tx = glm::normalize(glm::cross(up, N)), ty = glm::cross(N, tx);
    glm::dvec3 sum(0.0);
    double weight = 0.0;
    for (int s = 0; s < PREFILTER_SAMPLES; ++s) {
        const glm::dvec3 hl = lightmath::ggxHalfVector(lightmath::hammersley(uint32_t(s), PREFILTER_SAMPLES), alpha);
        const glm::dvec3 H = tx * hl.x + ty * hl.y + N * hl.z;
        const glm::dvec3 L = 2.0 * glm::dot(N, H) * H - N;
        const double NdotL = glm::dot(N, L);
        if (NdotL <= 0) continue;
        // pdf of L with N = v: D(h) h.z / (4 v.h) = D / 4; the sample stands for
        // 1 / (samples pdf) steradians.
        const double pdf = lightmath::distributionGGX(hl.z, alpha) / 4;
        const double lod = 0.5 * std::log2(1.0 / (PREFILTER_SAMPLES * pdf * texelSolidAngle)) + 1.0;
        sum += glm::dvec3(sampleAt(pyramid, L, lod)) * NdotL;
        weight += NdotL;
    }
    return glm::vec3(weight > 0 ? sum / weight : sum);
}

LatLong prefilterLevel(const std::vector<LatLong>& pyramid, int w, double roughness) {
    const int h = w / 2;
    LatLong out{w, h, std::vector<glm::vec3>(size_t(w) * size_t(h))};
    const double alpha = std::max(roughness * roughness, 1e-3);
    const double texelSolidAngle = 4 * lightmath::ENV_PI / (double(pyramid[0].w) * double(pyramid[0].h));
    // A row per piece on the process's workers.
    WorkerPool::shared().run(h, [&](int j) {
        for (int i = 0; i < w; ++i)
            out.c[size_t(j) * size_t(w) + size_t(i)] =
                prefilteredAt(pyramid, lightmath::envDirection((i + 0.5) / w, (j + 0.5) / h), alpha, texelSolidAngle);
    });
    return out;
}

// Six faces of size^2 texels (EnvLevels' cube layout), RGBA: the pyramid prefiltered for
// `roughness` about each texel's direction, or for roughness 0 read at the lod of the texel's
// solid angle (a cube texel's is (2 / size)^2 / |(sc, tc, 1)|^3).
std::vector<float> cubeLevel(const std::vector<LatLong>& pyramid, int size, double roughness, bool constant) {
    std::vector<float> out(size_t(6) * size_t(size) * size_t(size) * 4, 1.f);
    const double alpha = std::max(roughness * roughness, 1e-3);
    const double texelSolidAngle = 4 * lightmath::ENV_PI / (double(pyramid[0].w) * double(pyramid[0].h));
    WorkerPool::shared().run(6 * size, [&](int row) {
        const int face = row / size, j = row % size;
        for (int i = 0; i < size; ++i) {
            const double s = (i + 0.5) / size, t = (j + 0.5) / size;
            const glm::dvec3 d = lightmath::cubeDirection(face, s, t);
            glm::vec3 c;
            if (constant) {
                c = pyramid[0].c[0];
            } else if (roughness > 0.0) {
                c = prefilteredAt(pyramid, d, alpha, texelSolidAngle);
            } else {
                const double sc = 2 * s - 1, tc = 2 * t - 1;
                const double omega = std::pow(2.0 / size, 2.0) / std::pow(sc * sc + tc * tc + 1, 1.5);
                c = sampleAt(pyramid, d, std::max(0.0, 0.5 * std::log2(omega / texelSolidAngle)));
            }
            float* o = &out[((size_t(face) * size_t(size) + size_t(j)) * size_t(size) + size_t(i)) * 4];
            o[0] = c.x, o[1] = c.y, o[2] = c.z;
        }
    });
    return out;
}

} // namespace

EnvSun extractSun(ImageF& map, float minLuminance) {
    EnvSun sun;
    const int w = map.width, h = map.height;
    if (w <= 0 || h <= 0) return sun;
    auto lum = [&](size_t p) { return 0.2126 * map.rgba[p * 4] + 0.7152 * map.rgba[p * 4 + 1] + 0.0722 * map.rgba[p * 4 + 2]; };
    double total = 0, area = 0, peak = -1;
    size_t peakAt = 0;
    for (int j = 0; j < h; ++j) {
        const double dOmega = lightmath::envTexelSolidAngle(j, w, h);
        for (int i = 0; i < w; ++i) {
            const size_t p = size_t(j) * size_t(w) + size_t(i);
            const double l = lum(p);
            total += l * dOmega;
            area += dOmega;
            if (l > peak) peak = l, peakAt = p;
        }
    }
    const double mean = total / area;
    if (!(peak > SUN_PEAK_OVER_MEAN * mean) || !(mean > 0)) return sun;
    const glm::dvec3 centre = lightmath::envDirection((double(peakAt % size_t(w)) + 0.5) / w, (double(peakAt / size_t(w)) + 0.5) / h);
    const double cosRegion = std::cos(glm::radians(double(SUN_RADIUS_DEG))), cosRing = std::cos(glm::radians(2.0 * SUN_RADIUS_DEG));
    const double threshold = std::max(double(SUN_REGION_SHARE) * peak, 20.0 * mean);
    std::vector<size_t> region;
    glm::dvec3 ring(0.0);
    double ringArea = 0;
    // Only rows whose polar angle is within the ring's radius of the peak's can hold a texel of
    // the ring (angular distance >= difference of polar angles): a few per cent of a large map's
    // rows, since extractSuns scans once per light.
    const int jc = int(peakAt / size_t(w));
    const int band = int(std::ceil(2.0 * double(SUN_RADIUS_DEG) / 180.0 * h)) + 1;
    for (int j = std::max(0, jc - band); j <= std::min(h - 1, jc + band); ++j) {
        const double dOmega = lightmath::envTexelSolidAngle(j, w, h);
        for (int i = 0; i < w; ++i) {
            const size_t p = size_t(j) * size_t(w) + size_t(i);
            const double c = glm::dot(centre, lightmath::envDirection((i + 0.5) / w, (j + 0.5) / h));
            if (c < cosRing) continue;
            if (c >= cosRegion && lum(p) > threshold) region.push_back(p);
            else if (lum(p) <= threshold) ring += glm::dvec3(map.rgba[p * 4], map.rgba[p * 4 + 1], map.rgba[p * 4 + 2]) * dOmega, ringArea += dOmega;
        }
    }
    const glm::dvec3 fill = ringArea > 0 ? ring / ringArea : glm::dvec3(mean);
    glm::dvec3 power(0.0), direction(0.0);
    for (size_t p : region) {
        const int i = int(p % size_t(w)), j = int(p / size_t(w));
        const double dOmega = lightmath::envTexelSolidAngle(j, w, h);
        const glm::dvec3 c(map.rgba[p * 4], map.rgba[p * 4 + 1], map.rgba[p * 4 + 2]);
        const glm::dvec3 excess = glm::max(c - fill, glm::dvec3(0.0)) * dOmega;
        power += excess;
        direction += lightmath::envDirection((i + 0.5) / w, (j + 0.5) / h) * (0.2126 * excess.x + 0.7152 * excess.y + 0.0722 * excess.z);
    }
    if (glm::length(direction) <= 0) return sun;
    if (0.2126 * power.x + 0.7152 * power.y + 0.0722 * power.z < double(minLuminance)) return sun; // the map as it was
    for (size_t p : region)
        for (int k = 0; k < 3; ++k) map.rgba[p * 4 + size_t(k)] = std::min(map.rgba[p * 4 + size_t(k)], float(fill[k]));
    sun.found = true;
    sun.direction = glm::vec3(glm::normalize(direction));
    sun.irradiance = glm::vec3(power);
    return sun;
}

std::vector<EnvSun> extractSuns(ImageF& map) {
    std::vector<EnvSun> suns;
    auto luminance = [](const glm::vec3& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; };
    while (suns.size() < size_t(ENV_MAX_SUNS)) {
        const EnvSun sun = extractSun(map, suns.empty() ? 0.f : LAMP_SHARE_OF_SUN * luminance(suns[0].irradiance));
        if (!sun.found) break;
        suns.push_back(sun);
    }
    return suns;
}

EnvLevels prefilterEnvironment(const ImageF& src, int levels, int baseWidth, int cubeSize) {
    EnvLevels out;
    out.cube = cubeSize > 0;
    bool constant = true;
    for (size_t p = 4; p < src.rgba.size() && constant; p += 4)
        constant = src.rgba[p] == src.rgba[0] && src.rgba[p + 1] == src.rgba[1] && src.rgba[p + 2] == src.rgba[2];
    std::vector<LatLong> pyramid{resample(src, baseWidth, baseWidth / 2)};
    while (pyramid.back().w > 2) pyramid.push_back(halve(pyramid.back()));
    for (int k = 0; k < levels; ++k) {
        if (out.cube) {
            const int size = std::max(cubeSize >> k, 1);
            out.widths.push_back(size);
            out.rgba.push_back(cubeLevel(pyramid, size, double(k) / double(std::max(levels - 1, 1)), constant));
            continue;
        }
        const int w = std::max(baseWidth >> k, 2);
        out.widths.push_back(w);
        if (k == 0 || constant) {
            out.rgba.push_back(toRgba(pyramid[size_t(std::min<size_t>(size_t(k), pyramid.size() - 1))]));
        } else {
            out.rgba.push_back(toRgba(prefilterLevel(pyramid, w, double(k) / double(levels - 1))));
        }
    }
    for (const LatLong& l : pyramid) {
        if (l.w <= 128) {
            out.shWidth = l.w;
            out.shHeight = l.h;
            out.sh = toRgba(l);
            break;
        }
    }
    return out;
}

} // namespace dfb::engine
