// Issue 16 point 3, shadows without leaks at contacts: the engine's shadow masks against
// ray-traced hard shadows (Embree, a ray from each pixel's G-buffer position to the light), on
//  - the default tabletop (closed bunny and open table, vases and bowl),
//  - a closed mesh on a plane (the Stanford dragon standing on a ground quad),
//  - open meshes touching a plane under a grazing sun (a house without a floor and an open box,
//    lit at 80 degrees from the ground's and the box top's normal),
// for spot, directional, point (cube map) and BendyLight (deformed map) lights. Per light: the
// agreement of lit/shadowed over the pixels the light reaches (the mask's coverage), the shadowed
// area against the reference's, and on the grazing scene the acne on the lit convex box. Each
// light is measured twice: with hard shadows (shadowFilter 0: one bilinear comparison, the kind of
// shadow the reference is), where the thresholds apply, and with the default 3x3 soft
// filter, which by design narrows shadows thinner than its width (reported, with its own floors).
//
// A straight BendyLight renders like its spot light, so it is compared with the spot's ray-traced
// shadow. A bent one is compared with Picker::occluder, the server's own query for indirect
// editing: a ray from the source to each receiver's Q' against the casters subdivided and mapped
// Q -> Q' on the CPU, hits on the receiver's own surface (chords of a curved deformed surface)
// not counted. It is an approximation too (subdivided chords), so its agreement is asserted as
// measured floors only (BENT_FLOORS).

#include "support/Assets.h"
#include "support/FlatMesh.h"
#include "support/RayCaster.h"
#include "support/ShadowAgreement.h"

#include <dfb/gbuffer/Baker.h>
#include <dfb/server/BendyChain.h>
#include <dfb/server/Engine.h>
#include <dfb/server/Picker.h>

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

using namespace dfb;
using namespace dfb::lightmath;

namespace {

using test::flatPart;
using test::quad;

// Small enough for the whole test to stay well under a minute on llvmpipe.
constexpr int WIDTH = 320, HEIGHT = 180;

struct Shot {
    Scene scene;
    DeepBuffer buffer;
    std::unique_ptr<Engine> engine;
    std::unique_ptr<test::RayCaster> rays;
    std::unique_ptr<Picker> picker; // a bent BendyLight's reference: rays in its deformed space
    float radius = 1.f;
};

void finishShot(Shot& s, const BakeOptions& o) {
    s.scene.bounds = Bounds{};
    for (const MeshPart& p : s.scene.parts)
        for (const glm::vec3& v : p.positions) s.scene.bounds.extend(v);
    s.radius = s.scene.bounds.radius();
    auto b = bake(s.scene, o);
    ASSERT_TRUE(b.ok()) << b.error().toString();
    s.buffer = std::move(b.value());
    const ShadowGeometry casters = shadowCasters(s.scene);
    auto e = Engine::create(s.buffer, casters);
    ASSERT_TRUE(e.ok()) << e.error().toString();
    s.engine = std::move(e.value());
    auto picker = Picker::create(s.buffer, casters);
    ASSERT_TRUE(picker.ok()) << picker.error().toString();
    s.picker = std::move(picker.value());
    s.rays = std::make_unique<test::RayCaster>();
    for (const MeshPart& p : s.scene.parts) s.rays->addMesh(p.positions, p.indices);
    s.rays->commit();
}

Scene sceneWith(std::vector<std::string> names) {
    Scene s;
    s.materials.push_back(Material{});
    s.materials[0].metallic = 0.f;
    s.objectNames = std::move(names);
    return s;
}

// A ground square of side 2 half at y = 0, as cells x cells quads.
MeshPart ground(uint32_t id, float half, int cells = 1) {
    std::vector<glm::vec3> c;
    const float step = 2.f * half / float(cells);
    for (int i = 0; i < cells; ++i)
        for (int j = 0; j < cells; ++j) {
            const float x0 = -half + step * float(i), x1 = x0 + step, z0 = -half + step * float(j), z1 = z0 + step;
            quad(c, {x0, 0, z1}, {x1, 0, z1}, {x1, 0, z0}, {x0, 0, z0});
        }
    return flatPart(id, c);
}

void tabletop(Shot& s) {
    auto scene = loadScene(DFB_SOURCE_DIR "/scenes/tabletop.glb");
    ASSERT_TRUE(scene.ok()) << scene.error().toString();
    s.scene = std::move(scene.value());
    BakeOptions o;
    o.width = WIDTH;
    o.height = HEIGHT;
    finishShot(s, o);
}

// An asset mesh scaled to 2 units high, standing on a ground quad.
void meshOnPlane(Shot& s, const char* asset, bool closed, int groundCells = 1) {
    auto mesh = loadScene(test::assetPath(asset), LoadOptions{.loadImages = false});
    ASSERT_TRUE(mesh.ok()) << mesh.error().toString();
    s.scene = sceneWith({"ground", asset});
    s.scene.parts.push_back(ground(1, 5.f, groundCells));
    const Bounds& b = mesh->bounds;
    const float scale = 2.f / (b.max.y - b.min.y);
    const glm::vec3 foot(0.5f * (b.min.x + b.max.x), b.min.y, 0.5f * (b.min.z + b.max.z));
    for (MeshPart p : mesh->parts) {
        for (glm::vec3& v : p.positions) v = (v - foot) * scale;
        p.objectId = 2;
        p.materialId = 1;
        p.tangents.clear();
        p.uv0.clear();
        p.uv1.clear();
        p.colors.clear();
        EXPECT_EQ(isClosedMesh(p.positions, p.indices), closed) << asset;
        s.scene.parts.push_back(std::move(p));
    }
    BakeOptions o;
    o.width = WIDTH;
    o.height = HEIGHT;
    o.lookFrom = glm::vec3(1.2f, 2.6f, 5.2f);
    o.lookAt = glm::vec3(0.f, 0.7f, 0.f);
    o.fovDegrees = 45.f;
    finishShot(s, o);
}

// Open meshes touching the ground: a house without a floor (walls, gables and a pitched roof;
// its roof/wall and wall/ground lines are the contacts) and an open box (no bottom), convex,
// whose top is the acne test's receiver.
constexpr uint32_t BOX_ID = 3;
const glm::vec3 BOX_MIN(0.8f, 0.f, 0.4f), BOX_MAX(1.6f, 0.7f, 1.2f);

void openMeshesAtGrazingSun(Shot& s) {
    s.scene = sceneWith({"ground", "house", "box"});
    s.scene.parts.push_back(ground(1, 6.f));
    std::vector<glm::vec3> h;
    const float x0 = -1.8f, x1 = 0.2f, z0 = -1.2f, z1 = 0.6f, wall = 1.2f, ridge = 2.f, zm = 0.5f * (z0 + z1);
    quad(h, {x0, 0, z1}, {x1, 0, z1}, {x1, wall, z1}, {x0, wall, z1}); // front (+z)
    quad(h, {x1, 0, z0}, {x0, 0, z0}, {x0, wall, z0}, {x1, wall, z0}); // back (-z)
    quad(h, {x1, 0, z1}, {x1, 0, z0}, {x1, wall, z0}, {x1, wall, z1}); // +x
    quad(h, {x0, 0, z0}, {x0, 0, z1}, {x0, wall, z1}, {x0, wall, z0}); // -x
    h.insert(h.end(), {{x1, wall, z1}, {x1, wall, z0}, {x1, ridge, zm}}); // gables
    h.insert(h.end(), {{x0, wall, z0}, {x0, wall, z1}, {x0, ridge, zm}});
    quad(h, {x0, wall, z1}, {x1, wall, z1}, {x1, ridge, zm}, {x0, ridge, zm}); // roof, front slope
    quad(h, {x1, wall, z0}, {x0, wall, z0}, {x0, ridge, zm}, {x1, ridge, zm}); // back slope
    s.scene.parts.push_back(flatPart(2, h));
    std::vector<glm::vec3> c;
    const glm::vec3 a = BOX_MIN, b = BOX_MAX;
    quad(c, {a.x, b.y, b.z}, {b.x, b.y, b.z}, {b.x, b.y, a.z}, {a.x, b.y, a.z}); // top
    quad(c, {a.x, a.y, b.z}, {b.x, a.y, b.z}, {b.x, b.y, b.z}, {a.x, b.y, b.z}); // +z
    quad(c, {b.x, a.y, a.z}, {a.x, a.y, a.z}, {a.x, b.y, a.z}, {b.x, b.y, a.z}); // -z
    quad(c, {b.x, a.y, b.z}, {b.x, a.y, a.z}, {b.x, b.y, a.z}, {b.x, b.y, b.z}); // +x
    quad(c, {a.x, a.y, a.z}, {a.x, a.y, b.z}, {a.x, b.y, b.z}, {a.x, b.y, a.z}); // -x
    s.scene.parts.push_back(flatPart(BOX_ID, c));
    EXPECT_FALSE(isClosedMesh(s.scene.parts[1].positions, s.scene.parts[1].indices));
    EXPECT_FALSE(isClosedMesh(s.scene.parts[2].positions, s.scene.parts[2].indices));
    BakeOptions o;
    o.width = WIDTH;
    o.height = HEIGHT;
    o.lookFrom = glm::vec3(3.5f, 3.2f, 4.5f);
    o.lookAt = glm::vec3(-0.3f, 0.4f, 0.f);
    o.fovDegrees = 50.f;
    finishShot(s, o);
}

// The light types, each placed at `distance` from `target` towards `toLight` (unit).
Light spotAt(const glm::vec3& target, const glm::vec3& toLight, float distance, float cone) {
    Light l;
    l.name = "spot";
    const glm::vec3 p = target + toLight * distance;
    l.position = {p.x, p.y, p.z};
    l.direction = {-toLight.x, -toLight.y, -toLight.z};
    l.intensityCd = 10.f * distance * distance;
    l.coneAngleDeg = cone;
    l.penumbraDeg = 1.f;
    return l;
}

std::vector<Light> lightsFor(const glm::vec3& target, const glm::vec3& toLight, float distance, float cone, int filter) {
    const Light spot = spotAt(target, toLight, distance, cone);
    Light sun = spot;
    sun.name = "sun";
    sun.type = LightType::Directional;
    sun.intensityCd = 3.f;
    Light bulb = spot;
    bulb.name = "bulb";
    bulb.type = LightType::Point;
    Light straight = spot;
    straight.name = "bendy_straight";
    makeStraightChain(straight, 0.6f * distance, 2);
    // Bent sideways by about 50 degrees over its second segment (as bendy_light_render_test's
    // key, scaled to the distance).
    Light bent = spot;
    bent.name = "bendy_bent";
    bent.type = LightType::Bendy;
    const float k = distance / 5.f, tanTheta = std::tan(glm::radians(cone));
    bent.controlPoints = {{1.5f * k, 0.f, 0.f}, {3.f * k, 0.f, 0.f}, {4.2f * k, 0.f, 0.4f * k}, {4.8f * k, 0.f, 1.2f * k}};
    bent.radii = {0.f, 1.5f * k * tanTheta, 3.f * k * tanTheta, 3.6f * k * tanTheta, 4.1f * k * tanTheta};
    bent.colors.assign(5, Vec3{1.f, 1.f, 1.f});
    std::vector<Light> all{spot, sun, bulb, straight, bent};
    for (Light& l : all) l.shadowFilter = filter;
    return all;
}

struct Counts : test::ShadowCounts {
    size_t acne = 0, darkened = 0, acneReceivers = 0; // on the convex box's lit faces
};

// Engine (shadow mask, lit where the filtered visibility >= 0.5) against the ray-traced hard
// shadow, over the pixels the light reaches fully (the mask's coverage).
Counts measure(Shot& shot, const Light& light, bool acne) {
    Counts n;
    Rig rig;
    rig.lights = {light};
    auto mask = shot.engine->renderShadowMask(rig, light.name);
    EXPECT_TRUE(mask.ok()) << mask.error().toString();
    if (!mask.ok()) return n;
    const DeepBuffer& g = shot.buffer;
    const bool bent = light.type == LightType::Bendy && light.controlPoints.size() == 4 && light.controlPoints[3][2] != 0.f;
    test::forEachReachedPixel(mask.value(), g, [&](size_t, size_t s, float vis) {
        const glm::vec3 P = g.position(s), Ng(g.Ng[s * 3], g.Ng[s * 3 + 1], g.Ng[s * 3 + 2]);
        bool refLit;
        float cosine = 1.f; // a bent light's direction at P is the tube's: all counted as facing
        if (bent) {
            // The picker's occluder query: the ray p0 -> Q' against its deformed hierarchy of the
            // casters (split to 1 % of the radius, mapped Q -> Q'), hits on the receiver's own
            // surface (chords of a curved deformed surface) not counted.
            auto o = shot.picker->occluder(light, P, Ng);
            if (!o) return; // no foot: the light does not reach it
            refLit = !o->found;
        } else {
            refLit = test::rayTracedLit(*shot.rays, light, P, Ng, shot.radius);
            cosine = glm::dot(Ng, test::towardsLight(light, P));
        }
        const bool lit = vis >= 0.5f;
        n.add(lit, refLit, cosine);
        if (acne && g.objectId[s] == BOX_ID && refLit) {
            ++n.acneReceivers;
            n.acne += !lit;
            n.darkened += vis < 0.999f; // the filter's partial darkening too
        }
    });
    return n;
}

void report(const char* scene, const Light& l, const Counts& n) {
    std::printf("%-9s %-15s r=%d reached %6zu  agree %7.3f%%  shadowed engine %6zu ref %6zu (ratio %.4f)  "
                "lit-but-shadowed-in-ref %5zu  shadowed-but-lit-in-ref %5zu",
                scene, l.name.c_str(), l.shadowFilter, n.reached, 100.0 * n.agreement(), n.shadowedEngine, n.shadowedRef, n.areaRatio(),
                n.litHereShadowedRef, n.shadowedHereLitRef);
    std::printf("  facing: agree %7.3f%% ratio %.4f", 100.0 * n.facing.agreement(), n.facing.areaRatio());
    if (n.acneReceivers) std::printf("  acne %zu (darkened %zu) of %zu lit box pixels", n.acne, n.darkened, n.acneReceivers);
    std::printf("\n");
}

// The thresholds: lit/shadowed agreement >= 99.7% of the reached pixels, shadowed area
// within 1% of the reference's, no acne on the lit convex box, asserted on hard shadows.
// Measured 2026-12 (320x180, 2048 maps, receiver-plane depth bias and the baked near-field
// horizon, lightmath/Horizon.h): agreement 99.91-99.99 % and area 0.996-1.004 for every straight
// light on every scene. Before the horizon the area was 0.7-2.4 % short: curved meshes shadowed
// by their own neighbouring facets less than a texel or two along the ray (below the map's
// resolution, mostly near the terminator) and contacts seen at grazing angles were lit; the
// horizon closes them, and the lift it allows grazing receivers (nearFieldLift) keeps the
// two-sided dragon free of false self-shadow.
// Until the reference called a facet facing away from the light shadowed (rayTracedLit), the
// ratios read 0.98-1.00: its escaping rays had been counting terminator pixels as lit.
// A bent BendyLight's reference is approximate (see the file comment): its agreement is asserted
// as the measured floors below, its acne as zero (measured: tabletop 99.74 %, bunny 99.83 %,
// bunny on 4 x 4 quads 99.81 %, dragon 99.70 %, grazing 99.996 %, hard shadows). Until the
// tessellation levels took the curvature of every segment an edge spans and eq. 7's radius term
// (bendyEdgeLevel, bendy_deform.comp), the plane scenes were at 86-87 %: the ground's long edges
// were drawn as flat chords across the bend and shadowed 3,500 pixels of the ground.
constexpr double HARD_RATIO_TOLERANCE = 0.01;

struct BentFloor {
    const char* scene;
    double agreement;
};
const BentFloor BENT_FLOORS[] = {{"tabletop", 0.996}, {"bunny", 0.997}, {"bunny4", 0.997}, {"dragon", 0.996}, {"grazing", 0.9995}};

// With the default soft filter (3x3 texels) shadows thinner than the filter lose their middle to
// the 0.5 threshold: agreement still meets 99.7%, the area is short by up to 1.7% (the closed
// bunny's thin ears under the sun; 7 % before the horizon), never over by more than 0.4 %.
constexpr double SOFT_RATIO_FLOOR = 0.98;

void expectThresholds(const char* scene, const Light& l, const Counts& n, size_t minReached) {
    SCOPED_TRACE(std::string(scene) + " " + l.name + " filter " + std::to_string(l.shadowFilter));
    EXPECT_GE(n.reached, minReached);
    if (l.name == "bendy_bent") {
        for (const BentFloor& f : BENT_FLOORS) {
            if (std::string(scene) == f.scene) {
                EXPECT_GE(n.agreement(), f.agreement);
            }
        }
        return;
    }
    EXPECT_GE(n.agreement(), 0.997);
    EXPECT_GE(n.facing.agreement(), 0.997);
    EXPECT_GE(n.areaRatio(), l.shadowFilter > 0 ? SOFT_RATIO_FLOOR : 1.0 - HARD_RATIO_TOLERANCE);
    EXPECT_LE(n.areaRatio(), 1.0 + HARD_RATIO_TOLERANCE);
}

void runScene(Shot& shot, const char* name, const glm::vec3& target, const glm::vec3& toLight, float distance,
              float cone, bool acne, size_t minReached) {
    for (int filter : {0, 1}) {
        for (const Light& l : lightsFor(target, toLight, distance, cone, filter)) {
            const Counts n = measure(shot, l, acne);
            report(name, l, n);
            expectThresholds(name, l, n, minReached);
            if (acne) {
                SCOPED_TRACE(l.name);
                EXPECT_GT(n.acneReceivers, 500u);
                EXPECT_EQ(n.acne, 0u);
                // Partially darkened by the filter (visibility in [0.5, 1)): a few pixels at the box's
                // edges, where taps reach the neighbouring face (measured up to 9 of 1,441).
                EXPECT_LE(n.darkened, n.acneReceivers / 100);
            }
        }
    }
}

} // namespace

TEST(ShadowBias, TabletopAgreesWithRayTracing) {
    Shot shot;
    ASSERT_NO_FATAL_FAILURE(tabletop(shot));
    const Bounds& b = shot.scene.bounds;
    const Rig rig = defaultRig({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z});
    const Light& key = rig.lights[0];
    const glm::vec3 pos(key.position[0], key.position[1], key.position[2]);
    const glm::vec3 dir = glm::normalize(glm::vec3(key.direction[0], key.direction[1], key.direction[2]));
    const float distance = 0.8f * glm::length(b.max - b.min);
    runScene(shot, "tabletop", pos + dir * distance, -dir, distance, key.coneAngleDeg, false, 10000);
}

// The low-resolution Stanford bunny: closed (drawn with its light-facing faces culled, so its far
// side casts) and coarse (3,674 triangles: large flat facets at the contact).
TEST(ShadowBias, ClosedMeshOnAPlaneAgreesWithRayTracing) {
    DFB_REQUIRE_ASSETS();
    Shot shot;
    ASSERT_NO_FATAL_FAILURE(meshOnPlane(shot, "stanford-bunny-lowres.glb", true));
    runScene(shot, "bunny", {0.f, 0.5f, 0.f}, glm::normalize(glm::vec3(-0.5f, 1.f, 0.6f)), 7.f, 35.f, false, 10000);
}

// The same with the ground as 4 x 4 quads: under the bent light their edges lie along the tube
// past its bend, where eq. 7's lateral scale s tan(theta) / R(s) curves them although the chain is
// straight there (the radius term of bendy_deform.comp's kappa_eff; without it 3,400 pixels at
// the image's right self-shadowed, 87.0 % agreement).
TEST(ShadowBias, ClosedMeshOnASubdividedPlaneAgreesWithRayTracing) {
    DFB_REQUIRE_ASSETS();
    Shot shot;
    ASSERT_NO_FATAL_FAILURE(meshOnPlane(shot, "stanford-bunny-lowres.glb", true, 4));
    // The bent light only: the straight lights' shadows do not depend on how the ground is cut.
    for (int filter : {0, 1})
        for (const Light& l : lightsFor({0.f, 0.5f, 0.f}, glm::normalize(glm::vec3(-0.5f, 1.f, 0.6f)), 7.f, 35.f, filter)) {
            if (l.name != "bendy_bent") continue;
            const Counts n = measure(shot, l, false);
            report("bunny4", l, n);
            expectThresholds("bunny4", l, n, 10000);
        }
}

// The example: the Stanford dragon (47,794 triangles, not closed: drawn two-sided).
TEST(ShadowBias, DragonOnAPlaneAgreesWithRayTracing) {
    DFB_REQUIRE_ASSETS();
    Shot shot;
    ASSERT_NO_FATAL_FAILURE(meshOnPlane(shot, "stanford-dragon-48k.glb", false));
    runScene(shot, "dragon", {0.f, 0.5f, 0.f}, glm::normalize(glm::vec3(-0.5f, 1.f, 0.6f)), 7.f, 35.f, false, 10000);
}

TEST(ShadowBias, OpenMeshesAtAGrazingSunAgreeWithRayTracingWithoutAcne) {
    Shot shot;
    ASSERT_NO_FATAL_FAILURE(openMeshesAtGrazingSun(shot));
    // 80 degrees from the ground's and the box top's normal, from +x and a little +z.
    const float elevation = glm::radians(10.f);
    const glm::vec3 toLight = glm::normalize(glm::vec3(std::cos(elevation) * 0.94f, std::sin(elevation), std::cos(elevation) * 0.34f));
    const glm::vec3 boxTop(0.5f * (BOX_MIN.x + BOX_MAX.x), BOX_MAX.y, 0.5f * (BOX_MIN.z + BOX_MAX.z));
    runScene(shot, "grazing", boxTop, toLight, 8.f, 30.f, true, 10000);
}
