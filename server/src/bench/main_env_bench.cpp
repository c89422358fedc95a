// dfb-env-bench: the environment light's fast path (order-3 spherical harmonics against the
// shot's baked visibility, the split sum against the prefiltered map) against the brute-force
// reference (renderEnvironmentReference: Embree rays per sample, the layered BRDF), and its
// edit -> frame times (issue 19 points 4 and 5). A benchmark prints numbers; nothing here passes
// or fails.
//
//   dfb-env-bench SHOT.exr [--scene S.glb] [--maps DIR] [--map NAME ...] [--rays N] [--edits N]
//                 [--no-errors] [--unshadowed] [--transfer-bands] [--specular-bins] [--specular-bands]
//                 [--specular-lobes [--lobe-rays N]]
//
// Errors, per map (default: scenes/env's sunrise, an outdoor map with a sun, and interior): the
// shot as Lambert (specular 0, metallic 0: the diffuse term), as a metal of its own roughness
// (metallic 1: the specular term) and as baked; per covered pixel the luminance's relative error
// |fast - ref| / ref (pixels with ref above 1e-3 of the mean), mean and 95th percentile, and the
// aggregate sum |fast - ref| / sum ref. Shadowed when the shot holds the transfer (dfb-bake
// --env-rays), unshadowed otherwise (the reference then traces no rays either).
//
// --transfer-bands: per map, the diffuse row as the engine's formula would give it with a transfer
// of 3, 5, 7 and 9 spherical-harmonic bands (TransferBands.h, on the CPU): what the order-3
// visibility costs, and what a finer one would give. --specular-bins: the specular row's error per
// quarter of N.v and of roughness, unshadowed and shadowed: where the split sum and the specular
// occlusion miss. --specular-bands: the specular row as a baked specular transfer of 3, 5, 7 and 9
// bands would give it (SpecularBands.h, on the CPU), alone and for the rough samples only beside
// the engine's split sum. --specular-lobes: the specular row with each sample's visible lobe read
// from the prefiltered map once per group of its GGX rays (clusters, bins of the sampling domain,
// the polar rings of format version 7: SpecularLobes.h, on the CPU, N rays per sample).

#include <dfb/core/Stats.h>
#include <dfb/core/Version.h>
#include <dfb/server/Engine.h>
#include <dfb/server/EnvironmentReference.h>

#include "BenchShot.h"
#include "EnvFigures.h"
#include "SpecularBands.h"
#include "SpecularLobes.h"
#include "TransferBands.h"

#include <dfb/server/ImageCodec.h>

#include <dfb/core/CommandLine.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>

using namespace dfb;
using dfb::bench::compare;
using dfb::bench::Figures;
using dfb::bench::variant;
using Clock = std::chrono::steady_clock;

namespace {

double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

double median(std::vector<double> v) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"dfb-env-bench: the environment light against its brute-force reference, and edit -> frame times"};
    app.set_version_flag("--version", dfb::versionText("dfb-env-bench"));
    std::string shotPath, scenePath, mapDir = DFB_SOURCE_DIR "/scenes/env";
    std::vector<std::string> maps{"sunrise.exr", "interior.exr"};
    // 1,024 reference rays: at 256 the reference's own noise was 1-2 points of FlightHelmet's
    // diffuse mean (6.8 % against 4.2 % at 1,024 under interior.exr).
    int rays = 1024, edits = 10, lobeRays = 256;
    bool skipErrors = false;
    app.add_option("shot", shotPath, "deep framebuffer EXR")->required();
    app.add_option("--scene", scenePath, "the scene the reference traces (default: the shot's source scene)");
    app.add_option("--maps", mapDir, "the folder of the maps");
    app.add_option("--map", maps, "maps in that folder (repeat)");
    app.add_option("--lobe-rays", lobeRays, "--specular-lobes' GGX rays per sample (the bake's)")->check(CLI::Range(1, 65536));
    app.add_option("--rays", rays, "the reference's rays per sample")->check(CLI::Range(3, 65536))->capture_default_str();
    app.add_option("--edits", edits, "timed edits per row")->check(CLI::Range(1, 1000));
    app.add_flag("--no-errors", skipErrors, "only the edit -> frame times");
    bool unshadowed = false;
    app.add_flag("--unshadowed", unshadowed, "without visibility on both sides (the split sum and the irradiance alone)");
    bool specularBins = false;
    app.add_flag("--specular-bins", specularBins, "the specular row's error by N.v and roughness, unshadowed and shadowed");
    bool transferBands = false;
    app.add_flag("--transfer-bands", transferBands,
                 "the diffuse row with a transfer of 3, 5, 7 and 9 bands (the engine's formula on the CPU)");
    bool specularBands = false;
    // --specular-bands' hybrid rows: the transfer where the roughness is at least this (the
    // tabletop's table, 0.5-0.75), the engine's split sum below.
    constexpr float SPECULAR_TRANSFER_MIN_ROUGHNESS = 0.4f;
    app.add_flag("--specular-bands", specularBands,
                 "the specular row with a baked specular transfer of 3, 5, 7 and 9 bands (on the CPU: SpecularBands.h)");
    bool specularLobes = false;
    app.add_flag("--specular-lobes", specularLobes,
                 "the specular row with each sample's visible lobe as 1-4 prefiltered reads: clusters, bins, rings (on the CPU: SpecularLobes.h)");
    if (const int rc = dfb::parseCommandLine(app, argc, argv, "dfb-env-bench"); rc >= 0) return rc;
    keepFreedMemoryForFrames();

    bench::BenchShot opened;
    if (int rc = bench::openBenchShot("dfb-env-bench", shotPath, scenePath, opened)) return rc;
    const DeepBuffer& g = opened.shot;
    const bool transfer = !g.envTransfer.empty();
    std::printf("%s: %dx%d, %zu samples, visibility transfer %s\n", shotPath.c_str(), g.width, g.height, g.sampleCount(),
                transfer ? "baked" : "absent (unshadowed)");
    TriangleBvh bvh;
    for (const MeshPart& p : opened.scene.parts) bvh.addMesh(p.positions, p.indices);
    bvh.commit();
    const Bounds& b = opened.scene.bounds;
    const float radius = 0.5f * glm::length(b.max - b.min);

    Light env;
    env.name = "dome";
    env.type = LightType::Environment;
    env.intensityCd = 1.f;
    env.shadow = transfer && !unshadowed;
    // The environment light `l` alone on `v` by the engine and by the reference (traced against the
    // scene when `l` is shadowed); on failure nothing, with `failure` the exit code, after printing
    // why.
    int failure = 0;
    struct Pair {
        ImageF fast, ref;
        double refMs = 0;
    };
    auto fastAndReference = [&](const DeepBuffer& v, const Light& l) -> std::optional<Pair> {
        auto engine = Engine::create(v, opened.casters);
        if (!engine) {
            std::cerr << "dfb-env-bench: " << engine.error().toString() << "\n";
            failure = 3;
            return std::nullopt;
        }
        engine.value()->setAssetDirectory(mapDir);
        Rig rig;
        rig.lights = {l};
        auto fast = engine.value()->renderLightLinear(rig, l.name);
        const auto t0 = Clock::now();
        auto ref = renderEnvironmentReference(v, l.shadow ? &bvh : nullptr, radius, l, mapDir, rays);
        const double refMs = msSince(t0);
        if (!fast || !ref) {
            std::cerr << "dfb-env-bench: " << (fast ? ref.error() : fast.error()).toString() << "\n";
            failure = 1;
            return std::nullopt;
        }
        return Pair{std::move(fast.value()), std::move(ref.value()), refMs};
    };
    if (!skipErrors) {
        std::printf(" fast path vs reference (%d rays per sample), luminance relative error per pixel: mean / p95 / aggregate\n", rays);
        for (const std::string& map : maps) {
            env.envMap = map;
            for (const char* kind : {"diffuse", "specular", "baked"}) {
                const DeepBuffer v = variant(g, kind);
                auto pair = fastAndReference(v, env);
                if (!pair) return failure;
                const Figures f = compare(pair->fast, pair->ref, v);
                std::printf("  %-14s %-9s mean %6.2f%%  p95 %6.2f%%  aggregate %6.2f%%  (%zu pixels; reference %.1f s)\n", map.c_str(),
                            kind, 100 * f.mean, 100 * f.p95, 100 * f.aggregate, f.pixels, pair->refMs / 1000);
            }
        }
    }

    if (specularBins) {
        // Where the specular row's error is: per pixel by N.v and roughness (the first sample's).
        const DeepBuffer metal = variant(g, "specular");
        std::printf(" the specular row by N.v (rows) and roughness (columns), quarters of [0, 1]: mean |error| (mean signed\n"
                    " error) [pixels], against the reference on %d rays\n", rays);
        for (const std::string& map : maps)
            for (bool shadowed : {false, true}) {
                if (shadowed && !transfer) continue;
                Light l = env;
                l.envMap = map;
                l.shadow = shadowed;
                auto pair = fastAndReference(metal, l);
                if (!pair) return failure;
                const bench::QuarterBins bins = bench::binByViewAndRoughness(pair->fast, pair->ref, metal);
                std::printf("  %s, %s:\n", map.c_str(), shadowed ? "shadowed" : "unshadowed");
                for (int a = 0; a < 4; ++a) {
                    std::printf("   N.v < %.2f", 0.25 * (a + 1));
                    for (int r = 0; r < 4; ++r) {
                        const auto& c = bins.cell[a][r];
                        if (c.pixels) std::printf("  %6.1f%% (%+6.1f%%) [%5zu]", 100 * c.absolute / double(c.pixels), 100 * c.signedSum / double(c.pixels), c.pixels);
                        else std::printf("  %26s", "-");
                    }
                    std::printf("\n");
                }
            }
    }
    // The map `map` as read (its suns in) and the reference of shot `v` under the light `l` with it,
    // for the CPU models below; false (the error printed) when either fails.
    auto mapAndReference = [&](const DeepBuffer& v, const Light& l, ImageF& image, ImageF& reference) {
        auto img = readHdrImage((std::filesystem::path(mapDir) / l.envMap).string(), MAX_ENV_MAP_WIDTH, MAX_ENV_MAP_HEIGHT);
        if (!img) {
            std::cerr << "dfb-env-bench: " << img.error().toString() << "\n";
            return false;
        }
        auto ref = renderEnvironmentReference(v, l.shadow ? &bvh : nullptr, radius, l, mapDir, rays);
        if (!ref) {
            std::cerr << "dfb-env-bench: " << ref.error().toString() << "\n";
            return false;
        }
        image = std::move(img.value());
        reference = std::move(ref.value());
        return true;
    };
    // One specular row of the CPU models: an image of the metal shot against its reference.
    auto specularRow = [&](const std::string& map, const std::string& what, const ImageF& image, const ImageF& ref,
                           const DeepBuffer& metal, bool shadow) {
        const Figures f = compare(image, ref, metal);
        std::printf("  %-14s %-34s %s  mean %6.2f%%  p95 %6.2f%%  aggregate %6.2f%%\n", map.c_str(), what.c_str(),
                    shadow ? "shadowed" : "open", 100 * f.mean, 100 * f.p95, 100 * f.aggregate);
    };
    if (transferBands) {
        const std::vector<int> bands{3, 5, 7, 9};
        const DeepBuffer lambert = variant(g, "diffuse");
        Light shadowed = env;
        shadowed.shadow = true;
        std::printf(" the diffuse row with a transfer of more bands (the engine's formula on the CPU, the transfer on %d rays\n"
                    " per sample, against the reference): mean / p95 / aggregate\n", rays);
        for (const std::string& map : maps) {
            shadowed.envMap = map;
            ImageF image, ref;
            if (!mapAndReference(lambert, shadowed, image, ref)) return 1;
            const auto images = bench::transferBandImages(lambert, bvh, radius, std::move(image), rays, bands);
            for (size_t i = 0; i < bands.size(); ++i) {
                const Figures f = compare(images[i], ref, lambert);
                std::printf("  %-14s %d bands (%2d coefficients)  mean %6.2f%%  p95 %6.2f%%  aggregate %6.2f%%\n", map.c_str(), bands[i],
                            bands[i] * bands[i], 100 * f.mean, 100 * f.p95, 100 * f.aggregate);
            }
        }
    }

    if (specularBands) {
        const std::vector<int> bands{3, 5, 7, 9};
        const DeepBuffer metal = variant(g, "specular");
        std::printf(" the specular row with a baked specular transfer (on the CPU, %d GGX rays per sample, against the\n"
                    " reference): mean / p95 / aggregate; \"direct\": the rays' own estimate\n", rays);
        for (const std::string& map : maps) {
            Light l = env;
            l.envMap = map;
            ImageF image, ref;
            if (!mapAndReference(metal, l, image, ref)) return 1;
            const auto images = bench::specularBandImages(metal, bvh, radius, std::move(image), rays, bands, l.shadow);
            // The engine's split sum where the lobe is narrow, the transfer where it is wide.
            auto engine = Engine::create(metal, opened.casters);
            if (!engine) {
                std::cerr << "dfb-env-bench: " << engine.error().toString() << "\n";
                return 3;
            }
            engine.value()->setAssetDirectory(mapDir);
            Rig rig;
            rig.lights = {l};
            auto fast = engine.value()->renderLightLinear(rig, l.name);
            if (!fast) {
                std::cerr << "dfb-env-bench: " << fast.error().toString() << "\n";
                return 1;
            }
            auto hybrid = [&](const ImageF& transferImage) {
                ImageF out = fast.value();
                for (size_t p = 0; p < metal.pixelCount(); ++p) {
                    const uint32_t s0 = metal.sampleOffset[p];
                    if (s0 == metal.sampleOffset[p + 1] || metal.brdf[size_t(s0) * 4 + 1] < SPECULAR_TRANSFER_MIN_ROUGHNESS) continue;
                    for (int k = 0; k < 3; ++k) out.rgba[p * 4 + size_t(k)] = transferImage.rgba[p * 4 + size_t(k)];
                }
                return out;
            };
            auto row = [&](const std::string& what, const ImageF& img) { specularRow(map, what, img, ref, metal, l.shadow); };
            row("engine (split sum)", fast.value());
            row("direct (the rays' own estimate)", images[bands.size()]);
            for (size_t i = 0; i < bands.size(); ++i) {
                const std::string name = std::to_string(bands[i]) + " bands";
                row(name + ", RGB", images[i]);
                row(name + ", scalar x mean Fresnel", images[bands.size() + 1 + i]);
                row(name + ", scalar, rough only", hybrid(images[bands.size() + 1 + i]));
            }
        }
    }

    if (specularLobes) {
        const std::vector<int> clusters{1, 2, 3, 4, -122, -133, -144, -423};
        const DeepBuffer metal = variant(g, "specular");
        std::printf(" the specular row with the visible lobe as K prefiltered reads (on the CPU, %d GGX rays per sample),\n"
                    " against the reference: mean / p95 / aggregate\n", lobeRays);
        for (const std::string& map : maps) {
            Light l = env;
            l.envMap = map;
            ImageF image, ref;
            if (!mapAndReference(metal, l, image, ref)) return 1;
            const auto images = bench::specularLobeImages(metal, bvh, radius, std::move(image), lobeRays, clusters, l.shadow);
            auto row = [&](const std::string& what, const ImageF& img) { specularRow(map, what, img, ref, metal, l.shadow); };
            row("one read, the sample's roughness", images[clusters.size()]);
            for (size_t i = 0; i < clusters.size(); ++i) {
                const int c = clusters[i], a = -c / 100, p = (-c / 10) % 10, k = -c % 10;
                row(c > 0 ? std::to_string(c) + " k-means clusters of the rays"
                          : a == 1 && p == k ? std::to_string(p) + " polar rings"
                                             : std::to_string(a) + " x " + std::to_string(p) + " bins into " + std::to_string(k),
                    images[i]);
            }
        }
    }

    // Edit -> frame: the environment beside the scene's default key and fill.
    Engine& engine = *opened.engine;
    engine.setAssetDirectory(mapDir);
    Rig rig = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    env.envMap = maps.front();
    rig.lights.push_back(env);
    Light& dome = rig.lights.back();
    FrameStats st;
    if (auto r = engine.render(rig, &st); !r) {
        std::cerr << "dfb-env-bench: " << r.error().toString() << "\n";
        return 1;
    }
    auto timed = [&](const char* what, const std::function<void(int)>& edit) {
        std::vector<double> ms;
        for (int i = 0; i < edits; ++i) {
            edit(i);
            ++rig.version;
            const auto t0 = Clock::now();
            if (!engine.render(rig, &st)) return;
            ms.push_back(msSince(t0));
        }
        if (ms.empty()) return;
        std::printf("  %-30s first %7.1f ms, median %7.1f ms (%d edits; last: %d lights shaded, %d shadow maps of %ld caster "
                    "triangles: shadow %.1f, shade %.1f, composite %.1f, readback %.1f ms)\n",
                    what, ms[0], median(ms), edits, st.lightsShaded, st.shadowMapsRendered, st.shadowCasterTriangles, st.shadowMs,
                    st.shadeMs, st.compositeMs, st.readbackMs);
    };
    std::printf(" edit -> frame at %dx%d (the default key and fill plus the environment):\n", g.width, g.height);
    timed("environment rotation (yaw)", [&](int i) { dome.envRotationDeg[0] = float(10 * (i + 1)); });
    // The same turn as the server renders it while the rotation is dragged (--refine-window:
    // preview shadow maps and half-resolution shading, DESIGN section 6), and the full-quality
    // frame that refines it once the drag stops.
    {
        std::vector<double> dragged, refined;
        for (int i = 0; i < edits; ++i) {
            engine.setPreview(true);
            dome.envRotationDeg[0] = float(5 + 10 * i);
            ++rig.version;
            auto t0 = Clock::now();
            if (!engine.render(rig, &st)) break;
            dragged.push_back(msSince(t0));
            engine.setPreview(false);
            t0 = Clock::now();
            if (!engine.render(rig, &st)) break;
            refined.push_back(msSince(t0));
        }
        if (!dragged.empty()) {
            std::printf("  %-30s median %7.1f ms; the full-quality frame that refines it when the drag stops: median %7.1f ms\n",
                        "rotation while dragged", median(dragged), median(refined));
        }
    }
    if (std::getenv("DFB_ENV_BENCH_ROTATION_ONLY")) return 0;
    timed("environment intensity", [&](int i) { dome.intensityCd = 0.5f + 0.1f * float(i); });
    timed("key light move", [&](int i) { rig.lights[0].position[0] += (i % 2 ? -0.05f : 0.05f); });
    // The first swap reads and prefilters the map; the engine keeps the last few, so later ones don't.
    timed("environment map swap", [&](int i) { dome.envMap = maps[size_t(i + 1) % maps.size()]; });
    return 0;
}
