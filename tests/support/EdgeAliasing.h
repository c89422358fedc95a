#pragma once
// Test support: how well shadow, cone, barn-door and cookie edges anti-alias against silhouettes
// (issue 16 point 4), measured once for tests/gpu/engine_edge_aa_test.cpp (which asserts on it)
// and dfb-fidelity-bench (which prints it). Each case light of a scene is relit alone from bakes
// at 1, 4 and 16 samples per pixel and compared with the engine's own relight of a bake
// EDGE_REFERENCE_SCALE = 4 times larger each way, box-filtered: the 16 sub-pixels of a reference
// pixel are exactly the 4x4 stratified sample positions of the 16-spp bake (gbuffer-format.md).
// Edge pixels are the covered single-surface pixels whose reference sub-pixels disagree about the
// light's mask (its image over the same light without the feature: no shadow, open cone, open
// doors, no cookie); silhouette pixels those with several surfaces or partial coverage. Errors
// are the mean absolute error over the mean reference radiance of those pixels. No GoogleTest
// here: failures are Results naming the case.

#include <dfb/gbuffer/Baker.h>
#include <dfb/server/Engine.h>

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>
#include <unistd.h>
#include <utility>
#include <vector>

namespace dfb::test {

/// Reference sub-pixels per pixel, each way: 4 x 4 = the 16-spp bake's stratified positions.
constexpr int EDGE_REFERENCE_SCALE = 4;

/// One light under test and the same light without the edge-making feature.
struct EdgeCase {
    const char* name;
    Light light;
    Light companion;
};

/// A 28-degree spot (6 degrees of penumbra) aimed at a quarter of the way up the middle of the
/// scene's bounds from above and in front, at an intensity giving that point 2 lux.
inline Light aimedSpot(const Bounds& b, const char* name) {
    const glm::vec3 size = b.max - b.min;
    const float radius = 0.5f * glm::length(size);
    const glm::vec3 target = {0.5f * (b.min.x + b.max.x), b.min.y + 0.25f * size.y, 0.5f * (b.min.z + b.max.z)};
    Light l;
    l.name = name;
    const glm::vec3 pos = target + glm::vec3(-0.55f, 0.95f, 0.6f) * radius;
    const glm::vec3 dir = glm::normalize(target - pos);
    l.position = {pos.x, pos.y, pos.z};
    l.direction = {dir.x, dir.y, dir.z};
    l.intensityCd = 2.f * glm::dot(target - pos, target - pos);
    l.coneAngleDeg = 28.f;
    l.penumbraDeg = 6.f;
    return l;
}

/// The cases, placed from the scene's bounds: point, sun and spot shadows, a hard cone, barn
/// doors, a checker cookie ("checker.png", writeCheckerCookie) and dfb-bench's BendyLight shadow.
inline std::vector<EdgeCase> edgeCases(const Bounds& b) {
    const glm::vec3 size = b.max - b.min;
    std::vector<EdgeCase> cases;
    auto unshadowed = [](Light l) {
        l.shadow = false;
        return l;
    };
    {
        Light l = aimedSpot(b, "point");
        l.type = LightType::Point;
        l.shadowMapSize = 1024; // as dfb-bench's point light
        cases.push_back({"point shadow", l, unshadowed(l)});
    }
    {
        Light l = aimedSpot(b, "sun");
        l.type = LightType::Directional;
        l.direction = {0.45f, -0.8f, -0.4f};
        l.intensityCd = 2.f;
        cases.push_back({"sun shadow", l, unshadowed(l)});
    }
    {
        Light l = aimedSpot(b, "spot");
        cases.push_back({"spot shadow", l, unshadowed(l)});
    }
    {
        Light l = unshadowed(aimedSpot(b, "cone"));
        l.penumbraDeg = 0.f; // a hard cone edge
        Light open = l;
        open.coneAngleDeg = 80.f;
        cases.push_back({"spot cone", l, open});
    }
    {
        Light l = unshadowed(aimedSpot(b, "doors"));
        l.coneAngleDeg = 40.f;
        l.barnDoorsDeg = {12.f, 14.f, 9.f, 90.f};
        Light open = l;
        open.barnDoorsDeg = {90.f, 90.f, 90.f, 90.f};
        cases.push_back({"barn doors", l, open});
    }
    {
        Light l = unshadowed(aimedSpot(b, "cookie"));
        l.cookie = "checker.png";
        Light plain = l;
        plain.cookie.clear();
        cases.push_back({"cookie", l, plain});
    }
    {
        // dfb-bench's BendyLight: the key bent sideways.
        Light l = aimedSpot(b, "bendy");
        const float s = glm::length(size);
        makeStraightChain(l, 0.6f * s, 2);
        l.controlPoints[2][2] += 0.08f * s;
        l.controlPoints[3][2] += 0.2f * s;
        cases.push_back({"BendyLight shadow", l, unshadowed(l)});
    }
    return cases;
}

/// Writes a 256x256 black-and-white checker of 16-texel squares (hard edges) as an 8-bit image.
inline Status writeCheckerCookie(const std::filesystem::path& file) {
    std::vector<uint8_t> px(256 * 256);
    for (int y = 0; y < 256; ++y)
        for (int x = 0; x < 256; ++x) px[size_t(y) * 256 + size_t(x)] = ((x / 16 + y / 16) % 2) ? 255 : 0;
    auto out = OIIO::ImageOutput::create(file.string());
    if (!out || !out->open(file.string(), OIIO::ImageSpec(256, 256, 1, OIIO::TypeDesc::UINT8)) ||
        !out->write_image(OIIO::TypeDesc::UINT8, px.data()) || !out->close())
        return makeError(ErrorCode::IoError, file.string() + ": cannot write the checker cookie");
    return okStatus();
}

/// A folder of the temporary directory, made on construction and removed with everything in it
/// on destruction. Movable, not copyable.
class ScratchDir {
public:
    ScratchDir() = default;
    explicit ScratchDir(std::filesystem::path path) : mPath(std::move(path)) {
        std::filesystem::create_directories(mPath);
    }
    ScratchDir(ScratchDir&& other) noexcept : mPath(std::exchange(other.mPath, {})) {}
    ScratchDir& operator=(ScratchDir&& other) noexcept {
        if (this != &other) {
            remove();
            mPath = std::exchange(other.mPath, {});
        }
        return *this;
    }
    ScratchDir(const ScratchDir&) = delete;
    ScratchDir& operator=(const ScratchDir&) = delete;
    ~ScratchDir() { remove(); }

    const std::filesystem::path& path() const { return mPath; }

private:
    void remove() {
        std::error_code ignored;
        if (!mPath.empty()) std::filesystem::remove_all(mPath, ignored);
    }
    std::filesystem::path mPath;
};

/// A scene's bakes for the measurement: 1, 4 and 16 spp at width x height and the 1-spp
/// reference at EDGE_REFERENCE_SCALE times that each way, with the scene's casters, its cases and
/// a scratch folder holding the cases' cookie.
struct EdgeShots {
    ShadowGeometry casters;
    DeepBuffer spp[3]; ///< 1, 4, 16 samples per pixel
    DeepBuffer reference;
    std::vector<EdgeCase> cases;
    ScratchDir assets;
};

/// Bakes `scene` for the measurement (160x90: the figures engine_edge_aa_test asserts on).
inline Result<EdgeShots> bakeEdgeShots(const Scene& scene, int width = 160, int height = 90) {
    EdgeShots shots;
    const int rates[3] = {1, 4, 16};
    for (int i = 0; i < 3; ++i) {
        BakeOptions o;
        o.width = width;
        o.height = height;
        o.samples = rates[i];
        auto shot = bake(scene, o);
        if (!shot) return shot.error();
        shots.spp[i] = std::move(shot.value());
    }
    BakeOptions o;
    o.width = width * EDGE_REFERENCE_SCALE;
    o.height = height * EDGE_REFERENCE_SCALE;
    auto reference = bake(scene, o);
    if (!reference) return reference.error();
    shots.reference = std::move(reference.value());
    shots.casters = shadowCasters(scene);
    shots.cases = edgeCases(scene.bounds);
    shots.assets = ScratchDir(std::filesystem::temp_directory_path() / ("dfb_edge_aa_" + std::to_string(::getpid())));
    if (Status s = writeCheckerCookie(shots.assets.path() / "checker.png"); !s) return s.error();
    return shots;
}

/// Per case, in order: its light and its companion, each relit alone from `shot` by a fresh
/// engine (linear radiance).
using LitEdgeCases = std::vector<std::pair<ImageF, ImageF>>;

inline Result<LitEdgeCases> relightEdgeCases(const EdgeShots& shots, const DeepBuffer& shot) {
    auto engine = Engine::create(shot, shots.casters);
    if (!engine) return engine.error();
    engine.value()->setAssetDirectory(shots.assets.path().string());
    LitEdgeCases out;
    for (const EdgeCase& c : shots.cases) {
        Rig rig;
        rig.lights = {c.light};
        auto a = engine.value()->renderLightLinear(rig, c.light.name);
        if (!a) return makeError(a.error().code, std::string(c.name) + ": " + a.error().message);
        rig.lights = {c.companion};
        auto b = engine.value()->renderLightLinear(rig, c.companion.name);
        if (!b) return makeError(b.error().code, std::string(c.name) + " (companion): " + b.error().message);
        out.emplace_back(std::move(a.value()), std::move(b.value()));
    }
    return out;
}

struct EdgeErrors {
    double edge = 0, silhouette = 0; ///< mean absolute error over the mean reference radiance
    size_t edgePixels = 0, silhouettePixels = 0;
};

/// The errors of `img` (the size of shots.spp) against the box-filtered reference relight `ref`
/// (with its companion `refPlain`) on edge and silhouette pixels, classified from the 16-spp shot.
inline EdgeErrors measureEdgeErrors(const EdgeShots& shots, const ImageF& img, const ImageF& ref,
                                    const ImageF& refPlain) {
    constexpr int F = EDGE_REFERENCE_SCALE;
    const DeepBuffer& d = shots.spp[2];
    const int W = d.width, H = d.height;
    const size_t bigW = size_t(W) * F;
    double edgeErr = 0, edgeRef = 0, silErr = 0, silRef = 0;
    EdgeErrors e;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const float cov = d.coverage(x, y);
            const bool silhouette = d.pixelSamples(x, y) > 1 || (cov > 0.f && cov < 0.999f);
            bool edge = false;
            if (!silhouette && cov > 0.f) {
                // The light's mask at each sub-pixel: its luminance over the companion's.
                float lo = 1e30f, hi = -1e30f;
                bool all = true;
                for (int j = 0; j < F && all; ++j)
                    for (int i = 0; i < F; ++i) {
                        const size_t k = ((size_t(y) * F + size_t(j)) * bigW + size_t(x) * F + size_t(i)) * 4;
                        const float a = ref.rgba[k] + ref.rgba[k + 1] + ref.rgba[k + 2];
                        const float p = refPlain.rgba[k] + refPlain.rgba[k + 1] + refPlain.rgba[k + 2];
                        if (p <= 1e-6f) {
                            all = false;
                            break;
                        }
                        lo = std::min(lo, a / p);
                        hi = std::max(hi, a / p);
                    }
                edge = all && hi - lo > 0.25f;
            }
            if (!edge && !silhouette) continue;
            double err = 0, mean = 0;
            for (int c = 0; c < 3; ++c) {
                double r = 0;
                for (int j = 0; j < F; ++j)
                    for (int i = 0; i < F; ++i) r += ref.rgba[((size_t(y) * F + size_t(j)) * bigW + size_t(x) * F + size_t(i)) * 4 + size_t(c)];
                r /= F * F;
                err += std::abs(img.rgba[(size_t(y) * size_t(W) + size_t(x)) * 4 + size_t(c)] - r);
                mean += r;
            }
            if (edge) {
                edgeErr += err, edgeRef += mean, ++e.edgePixels;
            } else {
                silErr += err, silRef += mean, ++e.silhouettePixels;
            }
        }
    e.edge = edgeRef > 0 ? edgeErr / edgeRef : 0;
    e.silhouette = silRef > 0 ? silErr / silRef : 0;
    return e;
}

/// One case's errors at 1, 4 and 16 samples per pixel.
struct EdgeFigures {
    const char* name;
    EdgeErrors spp[3];
};

/// Every case of `shots` relit from the reference and from each bake, and measured.
inline Result<std::vector<EdgeFigures>> measureEdgeAliasing(const EdgeShots& shots) {
    auto ref = relightEdgeCases(shots, shots.reference);
    if (!ref) return ref.error();
    std::vector<LitEdgeCases> lit;
    for (const DeepBuffer& shot : shots.spp) {
        auto l = relightEdgeCases(shots, shot);
        if (!l) return l.error();
        lit.push_back(std::move(l.value()));
    }
    std::vector<EdgeFigures> figures;
    for (size_t c = 0; c < shots.cases.size(); ++c) {
        EdgeFigures f{shots.cases[c].name, {}};
        const auto& [refLit, refPlain] = ref->at(c);
        for (int i = 0; i < 3; ++i) f.spp[i] = measureEdgeErrors(shots, lit[size_t(i)][c].first, refLit, refPlain);
        figures.push_back(f);
    }
    return figures;
}

/// Prints the figures as a table, one case a line (pixel counts are the 16-spp shot's), each line
/// starting with `indent`.
inline void printEdgeFigures(const std::vector<EdgeFigures>& figures, const char* indent = "") {
    std::printf("%s%-18s %6s %6s | %-23s | %-23s | %-23s\n", indent, "light", "edge", "silh.", "1 spp: edge  silhouette",
                "4 spp: edge  silhouette", "16 spp: edge silhouette");
    for (const EdgeFigures& f : figures) {
        const EdgeErrors* e = f.spp;
        std::printf("%s%-18s %6zu %6zu | %9.2f%% %10.2f%% | %9.2f%% %10.2f%% | %9.2f%% %10.2f%%\n", indent, f.name, e[2].edgePixels,
                    e[2].silhouettePixels, 100 * e[0].edge, 100 * e[0].silhouette, 100 * e[1].edge, 100 * e[1].silhouette,
                    100 * e[2].edge, 100 * e[2].silhouette);
    }
}

} // namespace dfb::test
