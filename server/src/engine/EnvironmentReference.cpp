#include <dfb/server/EnvironmentReference.h>

#include <dfb/lightmath/Brdf.h>
#include <dfb/lightmath/Environment.h>
#include <dfb/server/ImageCodec.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <random>
#include <thread>
#include <vector>

namespace dfb {

namespace {

using lightmath::ENV_PI;

// The map as a piecewise-constant function over texels, with the 2D distribution of its
// luminance x sin(theta) (a marginal over rows, a conditional per row).
struct SampledMap {
    int w = 0, h = 0;
    std::vector<glm::vec3> c;
    std::vector<double> rowCdf;   // h + 1
    std::vector<double> colCdf;   // h x (w + 1)
    std::vector<double> texelP;   // probability of each texel

    glm::dvec3 radiance(const glm::dvec3& dMap) const {
        const glm::dvec2 uv = lightmath::envLatLong(dMap);
        const int i = std::clamp(int(std::floor(uv.x * w)), 0, w - 1) % w, j = std::clamp(int(std::floor(uv.y * h)), 0, h - 1);
        return glm::dvec3(c[size_t(j) * size_t(w) + size_t(i)]);
    }
    // Density per steradian of direction dMap: the texel's probability over its (u, v) area,
    // which covers (du dv) 2 pi^2 sin(theta) steradians at theta.
    double pdf(const glm::dvec3& dMap) const {
        const glm::dvec2 uv = lightmath::envLatLong(dMap);
        const int i = std::clamp(int(std::floor(uv.x * w)), 0, w - 1), j = std::clamp(int(std::floor(uv.y * h)), 0, h - 1);
        const double sinTheta = std::sqrt(std::max(0.0, 1 - dMap.y * dMap.y));
        if (sinTheta < 1e-9) return 0;
        return texelP[size_t(j) * size_t(w) + size_t(i)] * double(w) * double(h) / (2 * ENV_PI * ENV_PI * sinTheta);
    }
    glm::dvec3 sample(double a, double b, double c1, double c2) const {
        const int j = int(std::upper_bound(rowCdf.begin(), rowCdf.end(), a * rowCdf.back()) - rowCdf.begin()) - 1;
        const int jj = std::clamp(j, 0, h - 1);
        const double* row = &colCdf[size_t(jj) * size_t(w + 1)];
        const int i = std::clamp(int(std::upper_bound(row, row + w + 1, b * row[w]) - row) - 1, 0, w - 1);
        return lightmath::envDirection((i + c1) / w, (jj + c2) / h);
    }
};

Result<SampledMap> sampledMap(const Light& l, const std::string& assetDir) {
    SampledMap m;
    if (l.envMap.empty()) {
        m.w = 2;
        m.h = 1;
        m.c.assign(2, glm::vec3(1.f));
    } else {
        auto img = readHdrImage((std::filesystem::path(assetDir) / l.envMap).string(), MAX_ENV_MAP_WIDTH, MAX_ENV_MAP_HEIGHT);
        if (!img) return makeError(img.error().code, "light '" + l.name + "': map '" + l.envMap + "': " + img.error().message);
        m.w = img->width;
        m.h = img->height;
        m.c.resize(size_t(m.w) * size_t(m.h));
        for (size_t p = 0; p < m.c.size(); ++p) m.c[p] = glm::vec3(img->rgba[p * 4], img->rgba[p * 4 + 1], img->rgba[p * 4 + 2]);
    }
    m.rowCdf.assign(size_t(m.h) + 1, 0.0);
    m.colCdf.assign(size_t(m.h) * size_t(m.w + 1), 0.0);
    m.texelP.assign(m.c.size(), 0.0);
    double total = 0;
    for (int j = 0; j < m.h; ++j) {
        const double s = std::sin(ENV_PI * (j + 0.5) / m.h);
        double* row = &m.colCdf[size_t(j) * size_t(m.w + 1)];
        for (int i = 0; i < m.w; ++i) {
            const glm::vec3 c = m.c[size_t(j) * size_t(m.w) + size_t(i)];
            // A floor keeps every direction reachable (black texels included).
            const double wgt = (0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b + 1e-4) * s;
            row[i + 1] = row[i] + wgt;
            m.texelP[size_t(j) * size_t(m.w) + size_t(i)] = wgt;
        }
        m.rowCdf[size_t(j) + 1] = m.rowCdf[size_t(j)] + row[m.w];
        total += row[m.w];
    }
    for (double& p : m.texelP) p /= total;
    return m;
}

glm::dvec3 toDvec(const float* p) { return glm::dvec3(p[0], p[1], p[2]); }

} // namespace

Result<ImageF> renderEnvironmentReference(const DeepBuffer& g, const TriangleBvh* scene, float sceneRadius, const Light& l,
                                          const std::string& assetDir, int rays) {
    if (l.type != LightType::Environment) return makeError(ErrorCode::InvalidValue, "light '" + l.name + "' is not an environment light");
    if (rays < 1 || rays > 65536) return makeError(ErrorCode::InvalidValue, "reference rays " + std::to_string(rays) + " out of range 1..65536");
    auto map = sampledMap(l, assetDir);
    if (!map) return map.error();
    const SampledMap& m = map.value();
    const glm::dmat3 R = lightmath::envRotation(l.envRotationDeg), Rt = glm::transpose(R);
    const glm::dvec3 scale = glm::dvec3(toDvec(l.color.data())) * double(l.intensityCd);
    const bool shadowed = l.shadow && scene;
    const glm::dvec3 eye = glm::dvec3(g.camera.position()), forward = glm::dvec3(g.camera.forward());
    const double hair = 1e-5 * sceneRadius, reach = 4.0 * sceneRadius;

    std::vector<glm::dvec3> perSample(g.A.size(), glm::dvec3(0.0));
    std::atomic<size_t> next{0};
    auto work = [&] {
        constexpr size_t CHUNK = 64;
        for (size_t first = next.fetch_add(CHUNK); first < g.A.size(); first = next.fetch_add(CHUNK)) {
            for (size_t s = first; s < std::min(first + CHUNK, g.A.size()); ++s) {
                if (g.A[s] <= 0.f) continue;
                const glm::dvec3 P = glm::dvec3(g.position(s)), N = glm::normalize(glm::dvec3(g.normal(s)));
                const glm::dvec3 Ng = glm::normalize(toDvec(&g.Ng[s * 3]));
                const glm::dvec3 V = g.camera.orthographic ? -forward : glm::normalize(eye - P);
                const glm::dvec3 albedo = toDvec(&g.albedo[s * 3]);
                const glm::dvec4 brdf(g.brdf[s * 4], g.brdf[s * 4 + 1], g.brdf[s * 4 + 2], g.brdf[s * 4 + 3]);
                const glm::dvec4 sheen(g.sheen[s * 4], g.sheen[s * 4 + 1], g.sheen[s * 4 + 2], g.sheen[s * 4 + 3]);
                const glm::dvec2 coat(g.coat[s * 2], g.coat[s * 2 + 1]);
                const double alpha = std::max(brdf.y * brdf.y, double(lightmath::MIN_ALPHA));
                const glm::dvec3 up = std::abs(N.y) < 0.999 ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0);
                const glm::dvec3 tx = glm::normalize(glm::cross(up, N)), ty = glm::cross(N, tx);
                std::mt19937_64 rng(0x9E3779B97F4A7C15ull ^ uint64_t(s));
                std::uniform_real_distribution<double> U(0.0, 1.0);
                glm::dvec3 sum(0.0);
                // Each strategy's rays are a Hammersley set turned by a random offset per sample
                // and strategy (Cranley-Patterson rotation): stratified, unbiased.
                const int perStrategy = (rays + 2) / 3;
                glm::dvec2 offset[3];
                for (glm::dvec2& o : offset) o = {U(rng), U(rng)};
                for (int k = 0; k < rays; ++k) {
                    const glm::dvec2 xi = glm::fract(lightmath::hammersley(uint32_t(k / 3), uint32_t(perStrategy)) + offset[k % 3]);
                    glm::dvec3 w;
                    if (k % 3 == 0) {
                        w = R * m.sample(xi.x, xi.y, U(rng), U(rng));
                    } else if (k % 3 == 1) {
                        const double r = std::sqrt(xi.x), phi = 2 * ENV_PI * xi.y;
                        w = tx * (r * std::cos(phi)) + ty * (r * std::sin(phi)) + N * std::sqrt(std::max(0.0, 1 - r * r));
                    } else {
                        const glm::dvec3 h = lightmath::ggxHalfVector(xi, alpha);
                        const glm::dvec3 H = tx * h.x + ty * h.y + N * h.z;
                        w = 2.0 * glm::dot(V, H) * H - V;
                    }
                    const double NdotL = glm::dot(N, w);
                    if (NdotL <= 0) continue;
                    // The mixture's density (each strategy a third of the rays).
                    const glm::dvec3 H = glm::normalize(w + V);
                    const double NdotH = std::max(glm::dot(N, H), 0.0), VdotH = std::max(glm::dot(V, H), 1e-12);
                    const double pdf = (m.pdf(Rt * w) + NdotL / ENV_PI +
                                        lightmath::distributionGGX(NdotH, alpha) * NdotH / (4 * VdotH)) / 3.0;
                    if (!(pdf > 0)) continue;
                    if (shadowed && (glm::dot(Ng, w) <= 0 ||
                                     scene->occluded(glm::vec3(P + Ng * hair), glm::vec3(P + Ng * hair + w * reach), 1e-7f)))
                        continue;
                    const glm::dvec3 f = lightmath::evaluateLayeredBrdfCos(N, w, V, albedo, brdf, sheen, coat);
                    sum += f * m.radiance(Rt * w) / pdf;
                }
                perSample[s] = sum / double(rays) * scale * double(g.A[s]);
            }
        }
    };
    const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
    std::vector<std::thread> pool;
    for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work);
    work();
    for (std::thread& t : pool) t.join();

    ImageF out;
    out.width = g.width;
    out.height = g.height;
    out.rgba.assign(size_t(g.width) * size_t(g.height) * 4, 0.f);
    for (size_t p = 0; p < g.pixelCount(); ++p) {
        glm::dvec3 c(0.0);
        for (uint32_t s = g.sampleOffset[p]; s < g.sampleOffset[p + 1]; ++s) c += perSample[s];
        out.rgba[p * 4] = float(c.x);
        out.rgba[p * 4 + 1] = float(c.y);
        out.rgba[p * 4 + 2] = float(c.z);
        out.rgba[p * 4 + 3] = 1.f;
    }
    return out;
}

} // namespace dfb
