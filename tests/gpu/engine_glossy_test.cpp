// A glossy plane through the whole engine (Engine::renderLinear): roughness 0.3, metallic 0 and
// 1, lit by a point light and by a spot light with a penumbra and barn doors; every pixel above a
// small threshold must match dfb/lightmath/Brdf.h x Falloff.h evaluated for that pixel (light and
// view directions from the camera, N = +Y) within 1%. The first engine test with a specular lobe
// that matters (the others use specular 0, roughness 1).

#include <dfb/server/Engine.h>

#include <gtest/gtest.h>

#include "support/CpuRelight.h"
#include "support/PlaneShot.h"

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <cstdio>

using namespace dfb;

namespace {

constexpr int SIZE = 96;
const glm::vec3 ALBEDO(0.9f, 0.6f, 0.3f);

glm::vec3 planePoint(int x, int y) { return test::PlaneShot{}.point(x, y); }

// A SIZE x SIZE shot of the plane y = 0 seen from (0, 10, 0) (perspective), as engine_lights_test.
DeepBuffer glossyPlane(float metallic, float roughness) {
    test::PlaneShot p;
    p.albedo = ALBEDO;
    p.metallic = metallic;
    p.roughness = roughness;
    p.specular = 0.5f; // F0 = 0.04
    return p.shot();
}

// The expected linear radiance of pixel (x, y): f(L, V) N.L x colour x intensity x falloff.
glm::dvec3 expected(const Light& l, int x, int y, float metallic, float roughness) {
    test::SampleTerms s;
    s.P = glm::dvec3(planePoint(x, y));
    s.N = glm::dvec3(0, 1, 0);
    s.albedo = glm::dvec3(ALBEDO);
    s.brdf = glm::dvec4(metallic, roughness, 0.5, 1);
    return test::cpuShade(l, s, glm::normalize(glm::dvec3(0, 10, 0) - s.P));
}

struct Compare {
    int compared = 0, bad = 0;
    double worst = 0, peak = 0;
};

Compare compare(const Light& l, float metallic, float roughness) {
    Compare c;
    auto engine = Engine::create(glossyPlane(metallic, roughness), ShadowGeometry{});
    EXPECT_TRUE(engine.ok()) << engine.error().toString();
    if (!engine.ok()) return c;
    Rig rig;
    rig.lights.push_back(l);
    auto img = engine.value()->renderLinear(rig);
    EXPECT_TRUE(img.ok()) << img.error().toString();
    if (!img.ok()) return c;
    for (int y = 0; y < SIZE; ++y)
        for (int x = 0; x < SIZE; ++x) c.peak = std::max(c.peak, glm::length(expected(l, x, y, metallic, roughness)));
    // Threshold: 1e-3 of the brightest pixel (below it half floats and the cone's and doors' soft
    // edges, steep in a pixel, dominate; RGBA16F contributions carry 11 bits).
    const double threshold = 1e-3 * c.peak;
    for (int y = 0; y < SIZE; ++y)
        for (int x = 0; x < SIZE; ++x) {
            const glm::dvec3 e = expected(l, x, y, metallic, roughness);
            const float* px = &img->rgba[(size_t(y) * SIZE + size_t(x)) * 4];
            for (int k = 0; k < 3; ++k) {
                if (e[k] <= threshold) continue;
                ++c.compared;
                const double rel = std::abs(double(px[k]) - e[k]) / e[k];
                c.worst = std::max(c.worst, rel);
                if (rel > 0.01 && ++c.bad <= 5)
                    ADD_FAILURE() << l.name << " metallic " << metallic << " pixel (" << x << ", " << y << ") channel " << k
                                  << ": rendered " << px[k] << ", expected " << e[k];
            }
        }
    return c;
}

Light glossyPoint() {
    Light l;
    l.name = "bulb";
    l.type = LightType::Point;
    l.position = {0.6f, 1.2f, 0.4f}; // its highlight lands at about (0.53, 0, 0.35) on the plane
    l.color = {1.f, 0.9f, 0.8f};
    l.intensityCd = 3.f;
    l.shadow = false;
    return l;
}

Light glossySpot() {
    Light l;
    l.name = "spot";
    l.position = {-0.4f, 1.6f, 0.3f};
    l.direction = {0.3f, -1.f, -0.1f};
    l.color = {0.8f, 0.9f, 1.f};
    l.intensityCd = 5.f;
    l.coneAngleDeg = 40.f;
    l.penumbraDeg = 12.f;
    l.barnDoorsDeg = {35.f, 28.f, 90.f, 30.f};
    l.shadow = false;
    return l;
}

} // namespace

TEST(EngineGlossy, PointLightOnGlossyPlaneMatchesTheLobeWithinOnePercent) {
    for (float metallic : {0.f, 1.f}) {
        const Compare c = compare(glossyPoint(), metallic, 0.3f);
        std::printf("point light, roughness 0.3, metallic %.0f: %d values above 1e-3 of the peak (%.3g), worst relative "
                    "error %.2e, %d over 1%%\n",
                    metallic, c.compared, c.peak, c.worst, c.bad);
        EXPECT_GT(c.compared, 1000); // metallic 0: the whole plane; metallic 1: the highlight
        EXPECT_EQ(c.bad, 0);
    }
}

TEST(EngineGlossy, SpotLightWithPenumbraAndDoorsOnGlossyPlaneMatchesWithinOnePercent) {
    for (float metallic : {0.f, 1.f}) {
        const Compare c = compare(glossySpot(), metallic, 0.3f);
        std::printf("spot light (penumbra, doors), roughness 0.3, metallic %.0f: %d values above 1e-3 of the peak (%.3g), "
                    "worst relative error %.2e, %d over 1%%\n",
                    metallic, c.compared, c.peak, c.worst, c.bad);
        EXPECT_GT(c.compared, 1000);
        EXPECT_EQ(c.bad, 0);
    }
}
