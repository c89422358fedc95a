// dfb-fidelity-bench: how close the relight engine is to references, per scene (issue 16). A
// benchmark prints numbers; nothing here passes or fails (the tests assert the thresholds).
//
//   dfb-fidelity-bench [SCENE.glb ...] [--width W --height H] [--spp N] [--dump-shadows DIR]
//
// Per scene (default: the bundled tabletop and the Stanford dragon) it bakes a shot and prints:
// - shading: each light type alone, unshadowed, against a CPU relight of the same G-buffer samples
//   with dfb/lightmath (Brdf.h, Falloff.h) in double: worst and 99th-percentile relative error per
//   value, and the share of values off by more than 0.05 %;
// - specular 0: every sample's specular level set to 0 under a sun behind the scene at 11 degrees,
//   against Lambert (KHR_materials_specular's F90 = specular weight);
// - light cache: intensity edits from 1e-6 to 1e12 on the key light against a fresh engine;
// - shadows: the engine's shadow mask (lit where visibility >= 0.5) against Embree rays from each
//   fully reached pixel's sample to the light, per light type: agreement and shadowed-area ratio
//   (as tests/gpu/engine_shadow_bias_test.cpp measures them), over all of them and over the
//   receivers facing the light (test::FACING_COSINE); --dump-shadows writes each case's map of
//   disagreements as DIR/SCENE-LIGHT-rR.png (red: lit here, shadowed in the reference; blue: the
//   other way; grey: agreed, light where lit);
// - edges: shadow, cone, barn-door, cookie and BendyLight shadow edges at 1, 4 and 16 spp against
//   the engine's relight of a 4x4-times-resolution bake, box-filtered, beside the silhouettes'
//   error (tests/support/EdgeAliasing.h, whose 160x90 figures tests/gpu/engine_edge_aa_test.cpp
//   asserts on; always at 160x90 whatever --width and --height say).

#include <dfb/core/Version.h>
#include <dfb/core/Stats.h>
#include <dfb/gbuffer/Baker.h>
#include <dfb/gbuffer/Scene.h>
#include <dfb/server/Engine.h>

#include <dfb/core/CommandLine.h>
#include <CLI/CLI.hpp>

#include "support/CpuRelight.h"
#include "support/EdgeAliasing.h"
#include "support/RayCaster.h"
#include "support/ShadowAgreement.h"

#include <glm/glm.hpp>
#include <glm/gtc/packing.hpp>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

using namespace dfb;

namespace {

// The CPU relight of one light without shadows: per pixel, the coverage-weighted sum over its
// samples of test::cpuShade (f(L, V) N.L x colour x intensity x falloff, docs/lighting.md).
std::vector<glm::dvec3> cpuRelight(const DeepBuffer& b, const Light& l) {
    const glm::dvec3 eye(glm::inverse(b.camera.worldToCamera)[3]);
    const glm::dvec3 forward = glm::dvec3(b.camera.forward());
    std::vector<glm::dvec3> out(b.pixelCount(), glm::dvec3(0.0));
    for (size_t p = 0; p < b.pixelCount(); ++p) {
        for (uint32_t s = b.sampleOffset[p]; s < b.sampleOffset[p + 1]; ++s) {
            const double A = b.A[s];
            if (A <= 0) continue;
            test::SampleTerms t;
            t.P = glm::dvec3(b.position(s));
            t.N = glm::dvec3(b.normal(s));
            t.albedo = glm::dvec3(b.albedo[s * 3], b.albedo[s * 3 + 1], b.albedo[s * 3 + 2]);
            t.brdf = glm::dvec4(b.brdf[s * 4], b.brdf[s * 4 + 1], b.brdf[s * 4 + 2], b.brdf[s * 4 + 3]);
            t.sheen = glm::dvec4(b.sheen[s * 4], b.sheen[s * 4 + 1], b.sheen[s * 4 + 2], b.sheen[s * 4 + 3]);
            t.coat = glm::dvec2(b.coat[s * 2], b.coat[s * 2 + 1]);
            const glm::dvec3 V = b.camera.orthographic ? -forward : glm::normalize(eye - t.P);
            out[p] += A * test::cpuShade(l, t, V);
        }
    }
    return out;
}

// The layers the engine uploads as half float (GBufferTextures: all but P), rounded as a shot read
// from its EXR file holds them, so that the CPU relight sees the values the GPU reads.
void roundToHalf(DeepBuffer& b) {
    for (std::vector<float>* layer : {&b.N, &b.Ng, &b.T, &b.albedo, &b.brdf, &b.sheen, &b.coat, &b.emission, &b.A, &b.envTransfer})
        for (float& v : *layer) v = glm::unpackHalf1x16(glm::packHalf1x16(v));
}

struct Agreement {
    double worst = 0, p99 = 0, overShare = 0; // relative errors; share of values over 5e-4
    size_t values = 0;
};

// Relative error per value above 1e-3 of the reference's peak (darker values: error / that floor).
Agreement compare(const ImageF& gpu, const std::vector<glm::dvec3>& ref) {
    double peak = 0;
    for (const glm::dvec3& c : ref) peak = std::max(peak, std::max(c.x, std::max(c.y, c.z)));
    std::vector<double> errs;
    Agreement a;
    const double floor = 1e-3 * peak;
    size_t over = 0;
    for (size_t p = 0; p < ref.size(); ++p)
        for (int k = 0; k < 3; ++k) {
            const double want = ref[p][k], got = gpu.rgba[p * 4 + size_t(k)];
            if (want < floor && got < floor) continue;
            const double e = std::abs(got - want) / std::max(want, floor);
            errs.push_back(e);
            over += e > 5e-4 ? 1 : 0;
        }
    a.values = errs.size();
    if (errs.empty()) return a;
    a.worst = *std::max_element(errs.begin(), errs.end());
    a.p99 = percentile(errs, 99);
    a.overShare = double(over) / double(errs.size());
    return a;
}

void printAgreement(const char* what, const Agreement& a) {
    std::printf("  %-34s worst %9.2e  p99 %9.2e  over 0.05%%: %6.3f%% of %zu values\n", what, a.worst, a.p99, 100 * a.overShare,
                a.values);
}

// Relative difference of two float images, values above 1e-6 of the peak.
double worstRelative(const ImageF& a, const ImageF& b) {
    float peak = 0;
    for (float v : b.rgba) peak = std::max(peak, v);
    double worst = 0;
    for (size_t i = 0; i < a.rgba.size(); ++i) {
        if (i % 4 == 3) continue;
        const double m = std::max(std::abs(a.rgba[i]), std::abs(b.rgba[i]));
        if (m <= 1e-6 * peak) continue;
        worst = std::max(worst, std::abs(double(a.rgba[i]) - b.rgba[i]) / m);
    }
    return worst;
}

// The disagreement map of one shadow case (see the header comment), as an 8-bit PNG.
void dumpShadowMap(const std::filesystem::path& file, const DeepBuffer& g, const ImageF& mask, const test::RayCaster& rays,
                   const Light& l, float radius) {
    std::vector<uint8_t> px(g.pixelCount() * 3, 0);
    test::forEachReachedPixel(mask, g, [&](size_t p, size_t s, float vis) {
        const glm::vec3 Ng(g.Ng[s * 3], g.Ng[s * 3 + 1], g.Ng[s * 3 + 2]);
        const bool lit = vis >= 0.5f, refLit = test::rayTracedLit(rays, l, g.position(s), Ng, radius);
        const uint8_t grey = lit ? 170 : 60;
        const uint8_t rgb[3] = {lit && !refLit ? uint8_t(255) : (lit == refLit ? grey : uint8_t(0)),
                                lit == refLit ? grey : uint8_t(0),
                                !lit && refLit ? uint8_t(255) : (lit == refLit ? grey : uint8_t(0))};
        std::copy(rgb, rgb + 3, px.begin() + std::ptrdiff_t(p * 3));
    });
    auto out = OIIO::ImageOutput::create(file.string());
    if (!out || !out->open(file.string(), OIIO::ImageSpec(g.width, g.height, 3, OIIO::TypeDesc::UINT8)) ||
        !out->write_image(OIIO::TypeDesc::UINT8, px.data()) || !out->close())
        std::fprintf(stderr, "%s: cannot write\n", file.string().c_str());
}

int benchScene(const std::string& path, int width, int height, int spp, const std::string& dumpDir) {
    auto scene = loadScene(path);
    if (!scene) {
        std::fprintf(stderr, "%s\n", scene.error().toString().c_str());
        return 1;
    }
    BakeOptions o;
    o.width = width;
    o.height = height;
    o.samples = spp;
    auto shot = bake(scene.value(), o);
    if (!shot) {
        std::fprintf(stderr, "%s\n", shot.error().toString().c_str());
        return 1;
    }
    roundToHalf(shot.value());
    const ShadowGeometry casters = shadowCasters(scene.value());
    auto engine = Engine::create(shot.value(), casters);
    if (!engine) {
        std::fprintf(stderr, "%s\n", engine.error().toString().c_str());
        return 1;
    }
    const Bounds& bb = scene->bounds;
    const Rig base = defaultRig({bb.min.x, bb.min.y, bb.min.z}, {bb.max.x, bb.max.y, bb.max.z});
    std::printf("\n%s: %dx%d, %d spp, %zu samples, %zu shadow-casting triangles\n", path.c_str(), width, height, spp,
                shot->sampleCount(), casters.indices.size() / 3);

    // Shading: each light type alone, unshadowed.
    std::printf(" shading vs CPU relight (lightmath, double), unshadowed:\n");
    for (LightType t : {LightType::Spot, LightType::Point, LightType::Directional}) {
        Rig rig;
        Light l = base.lights[0];
        l.type = t;
        l.shadow = false;
        if (t == LightType::Point) l.intensityCd *= 0.5f;
        if (t == LightType::Directional) l.intensityCd = 2.f;
        l.barnDoorsDeg = {90.f, 60.f, 90.f, 90.f};
        if (t != LightType::Spot) l.barnDoorsDeg = {90.f, 90.f, 90.f, 90.f};
        rig.lights = {l};
        auto img = engine.value()->renderLightLinear(rig, l.name);
        if (!img) return 1;
        const char* names[] = {"spot (penumbra, one barn door)", "", "directional", "point"};
        printAgreement(names[int(t)], compare(img.value(), cpuRelight(shot.value(), l)));
    }

    // Specular 0 under a grazing sun behind the scene (as seen from the camera).
    {
        DeepBuffer flat = shot.value();
        for (size_t s = 0; s < flat.sampleCount(); ++s) flat.brdf[s * 4 + 2] = 0.f;
        auto e0 = Engine::create(flat, casters);
        if (!e0) return 1;
        const glm::vec3 f = shot->camera.forward();
        const glm::vec3 horizontal = glm::normalize(glm::vec3(f.x, 0.f, f.z) + glm::vec3(1e-6f, 0.f, 0.f));
        const glm::vec3 travel = glm::normalize(-horizontal * std::cos(glm::radians(11.f)) - glm::vec3(0, std::sin(glm::radians(11.f)), 0));
        Light sun;
        sun.name = "sun";
        sun.type = LightType::Directional;
        sun.direction = {travel.x, travel.y, travel.z};
        sun.intensityCd = 2.f;
        sun.shadow = false;
        Rig rig;
        rig.lights = {sun};
        auto img = e0.value()->renderLightLinear(rig, "sun");
        if (!img) return 1;
        printAgreement("specular 0, sun behind at 11 deg", compare(img.value(), cpuRelight(flat, sun)));
        auto img1 = engine.value()->renderLightLinear(rig, "sun");
        if (!img1) return 1;
        printAgreement("as baked, sun behind at 11 deg", compare(img1.value(), cpuRelight(shot.value(), sun)));
    }

    // Light cache: intensity edits on the key light (shadowed) against fresh engines.
    {
        Rig rig = base;
        if (!engine.value()->renderLinear(rig)) return 1;
        double worst = 0;
        const float cd[] = {1e-6f, 3e-6f, 3.f, 1e4f, 1e9f, 1e12f, 1e-3f};
        for (float c : cd) {
            rig.lights[0].intensityCd = c;
            auto edited = engine.value()->renderLinear(rig);
            auto fresh = Engine::create(shot.value(), casters);
            if (!edited || !fresh) return 1;
            auto want = fresh.value()->renderLinear(rig);
            if (!want) return 1;
            worst = std::max(worst, worstRelative(edited.value(), want.value()));
        }
        std::printf(" light cache: %zu intensity edits 1e-6 .. 1e12 vs fresh engines: worst relative difference %.2e\n",
                    std::size(cd), worst);
    }

    // Shadows against Embree, the default key light as spot, sun and point light.
    {
        test::RayCaster rays;
        for (const MeshPart& p : scene->parts) rays.addMesh(p.positions, p.indices);
        rays.commit();
        const float radius = 0.5f * glm::length(bb.max - bb.min);
        std::printf(" shadows vs Embree (lit where the mask's visibility >= 0.5; r: shadowFilter, 0 = hard as the\n"
                    " reference, 1 = the default 3x3 soft filter):\n");
        for (int filter : {0, 1})
            for (LightType t : {LightType::Spot, LightType::Directional, LightType::Point}) {
                Light l = base.lights[0];
                l.type = t;
                l.shadow = true;
                l.shadowFilter = filter;
                auto n = test::straightShadowAgreement(*engine.value(), shot.value(), rays, l, radius);
                if (!n) {
                    std::fprintf(stderr, "shadow mask: %s\n", n.error().toString().c_str());
                    return 1;
                }
                const char* names[] = {"spot", "", "directional", "point"};
                if (!dumpDir.empty()) {
                    Rig rig;
                    rig.lights = {l};
                    if (auto mask = engine.value()->renderShadowMask(rig, l.name))
                        dumpShadowMap(std::filesystem::path(dumpDir) / (std::filesystem::path(path).stem().string() + "-" +
                                                                         names[int(t)] + "-r" + std::to_string(filter) + ".png"),
                                      shot.value(), mask.value(), rays, l, radius);
                }
                std::printf("  %-12s r=%d agreement %7.3f%% of %zu reached pixels, shadowed area %.3f of the reference's;"
                            " facing (N_g.L >= %.1f): %7.3f%%, %.3f; lit here and shadowed there %zu, the other way %zu, of"
                            " %zu shadowed\n",
                            names[int(t)], filter, 100.0 * n->agreement(), n->reached, n->areaRatio(), test::FACING_COSINE,
                            100.0 * n->facing.agreement(), n->facing.areaRatio(), n->litHereShadowedRef, n->shadowedHereLitRef,
                            n->shadowedRef);
            }
    }

    // Edges against a 4x4-times-resolution bake, at the size the test asserts on.
    {
        auto shots = test::bakeEdgeShots(scene.value());
        if (!shots) {
            std::fprintf(stderr, "%s\n", shots.error().toString().c_str());
            return 1;
        }
        auto figures = test::measureEdgeAliasing(shots.value());
        if (!figures) {
            std::fprintf(stderr, "%s\n", figures.error().toString().c_str());
            return 1;
        }
        std::printf(" edges at %dx%d vs the engine's relight of a %dx%d bake, box-filtered (mean absolute error over\n"
                    " the mean reference radiance, on edge and on silhouette pixels):\n",
                    shots->spp[0].width, shots->spp[0].height, shots->reference.width, shots->reference.height);
        test::printEdgeFigures(figures.value(), "  ");
    }
    return 0;
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"dfb-fidelity-bench: relight fidelity against references (issue 16)"};
    app.set_version_flag("--version", dfb::versionText("dfb-fidelity-bench"));
    std::vector<std::string> scenes;
    int width = 480, height = 270, spp = 1;
    app.add_option("scenes", scenes, "glTF scenes (default: the bundled tabletop and the Stanford dragon)");
    app.add_option("--width", width, "bake width")->check(CLI::Range(16, 4096));
    app.add_option("--height", height, "bake height")->check(CLI::Range(16, 4096));
    app.add_option("--spp", spp, "bake samples per pixel")->check(CLI::Range(1, 64));
    std::string dumpDir;
    app.add_option("--dump-shadows", dumpDir, "write each shadow case's disagreement map as a PNG into this folder")
        ->check(CLI::ExistingDirectory);
    if (const int rc = dfb::parseCommandLine(app, argc, argv, "dfb-fidelity-bench"); rc >= 0) return rc;
    if (scenes.empty()) scenes = {DFB_SOURCE_DIR "/scenes/tabletop.glb", DFB_SOURCE_DIR "/tests/assets/stanford-dragon-48k.glb"};
    int rc = 0;
    for (const std::string& s : scenes) rc |= benchScene(s, width, height, spp, dumpDir);
    return rc;
}
