#include <dfb/gbuffer/LayerImage.h>

#include <algorithm>
#include <cmath>

namespace dfb {

const std::vector<std::string>& viewableLayers() {
    static const std::vector<std::string> names = {"P", "N", "Ng", "T", "Z", "albedo", "brdf", "occlusion",
                                                   "sheen", "coat", "emission", "A", "id", "material"};
    return names;
}

namespace {

float srgb(float c) {
    c = std::clamp(c, 0.f, 1.f);
    return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.f / 2.4f) - 0.055f;
}

glm::vec3 idColour(uint32_t id) {
    if (id == 0) return glm::vec3(0.f);
    uint32_t h = id * 2654435761u; // Knuth's multiplicative hash spreads neighbouring ids
    return {float((h >> 8) & 255) / 255.f, float((h >> 16) & 255) / 255.f, float((h >> 24) & 255) / 255.f};
}

} // namespace

Result<std::vector<uint8_t>> layerImage(const DeepBuffer& b, const std::string& layer) {
    const auto& names = viewableLayers();
    if (std::find(names.begin(), names.end(), layer) == names.end()) {
        std::string list;
        for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
        return makeError(ErrorCode::InvalidValue, "unknown layer '" + layer + "' (layers: " + list + ")");
    }
    glm::vec3 pmin(1e30f), pmax(-1e30f);
    float zmin = 1e30f, zmax = -1e30f;
    for (size_t s = 0; s < b.sampleCount(); ++s) {
        if (b.A[s] <= 0.f) continue;
        pmin = glm::min(pmin, b.position(s));
        pmax = glm::max(pmax, b.position(s));
        zmin = std::min(zmin, b.Z[s]);
        zmax = std::max(zmax, b.Z[s]);
    }
    std::vector<uint8_t> out(b.pixelCount() * 3, 0);
    for (size_t p = 0; p < b.pixelCount(); ++p) {
        glm::vec3 acc(0.f);
        float wsum = 0.f, best = 0.f;
        uint32_t bestS = ~0u;
        for (uint32_t s = b.sampleOffset[p]; s < b.sampleOffset[p + 1]; ++s) {
            const float a = b.A[s];
            if (a <= 0.f) continue;
            if (a > best) { best = a; bestS = s; }
            glm::vec3 v(0.f);
            auto get = [&](const std::vector<float>& L, int comps, int c) { return L[s * size_t(comps) + size_t(c)]; };
            if (layer == "P") v = (b.position(s) - pmin) / glm::max(pmax - pmin, glm::vec3(1e-20f));
            else if (layer == "N") v = 0.5f + 0.5f * b.normal(s);
            else if (layer == "Ng") v = 0.5f + 0.5f * glm::vec3(get(b.Ng, 3, 0), get(b.Ng, 3, 1), get(b.Ng, 3, 2));
            else if (layer == "T") v = 0.5f + 0.5f * glm::vec3(get(b.T, 4, 0), get(b.T, 4, 1), get(b.T, 4, 2));
            else if (layer == "Z") v = glm::vec3(1.f - (b.Z[s] - zmin) / std::max(zmax - zmin, 1e-20f));
            else if (layer == "albedo") v = {srgb(get(b.albedo, 3, 0)), srgb(get(b.albedo, 3, 1)), srgb(get(b.albedo, 3, 2))};
            else if (layer == "brdf") v = {get(b.brdf, 4, 0), get(b.brdf, 4, 1), get(b.brdf, 4, 2)};
            else if (layer == "occlusion") v = glm::vec3(get(b.brdf, 4, 3));
            else if (layer == "sheen") v = {srgb(get(b.sheen, 4, 0)), srgb(get(b.sheen, 4, 1)), srgb(get(b.sheen, 4, 2))};
            else if (layer == "coat") v = {get(b.coat, 2, 0), get(b.coat, 2, 1), 0.f};
            else if (layer == "emission") v = {srgb(get(b.emission, 3, 0)), srgb(get(b.emission, 3, 1)), srgb(get(b.emission, 3, 2))};
            else if (layer == "A") v = glm::vec3(1.f);
            acc += a * v;
            wsum += a;
        }
        glm::vec3 c(0.f);
        if (layer == "id" || layer == "material") {
            if (bestS != ~0u) c = idColour(layer == "id" ? b.objectId[bestS] : b.materialId[bestS]);
        } else if (layer == "A") {
            c = glm::vec3(std::min(wsum, 1.f));
        } else if (wsum > 0.f) {
            c = acc / wsum;
        }
        for (int k = 0; k < 3; ++k) out[p * 3 + size_t(k)] = uint8_t(std::lround(std::clamp(c[k], 0.f, 1.f) * 255.f));
    }
    return out;
}

} // namespace dfb
