// Cases for the browser's mirror of the rig model (client/web/rig.js): keyframed lights evaluated
// by protocol::evaluateRig at times before, at, between and after their keys, the light frame
// dfb::lightFrame gives for directions around the near-vertical switch of its up vector, area
// lights' emitter frames (lightmath::areaFrame: the light frame turned by roll), and the rig schema (GET /v1/schema) the page takes its rows from. They are written to
// DFB_TEST_DATA/protocol_parity_cases.json, the schema also alone to DFB_TEST_DATA/rig_schema.json
// (the node tests' rows); tests/web/parity.test.mjs (CTest web_parity, which requires this test's
// fixture, as web_modules does) checks that the JavaScript gives the same values.
// The page shows keyed values and places handles with its own copy of the math, so a difference
// would show the artist something else than the server renders.

#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Schema.h>
#include <dfb/lightmath/AreaLight.h>
#include <dfb/lightmath/Environment.h>
#include <dfb/server/BendyChain.h>
#include <dfb/server/BentArea.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <string>
#include <vector>

using namespace dfb;
using json = nlohmann::json;

namespace {

const std::string CASES = DFB_TEST_DATA "/protocol_parity_cases.json";
const std::string SCHEMA = DFB_TEST_DATA "/rig_schema.json";

json key(double t, json value, const char* interp = "linear") { return json{{"t", t}, {"value", std::move(value)}, {"interp", interp}}; }

json spot() {
    return json{{"name", "s"}, {"type", "spot"}, {"position", {0, 3, 3}}, {"direction", {0, -0.7071, -0.7071}},
                {"coneAngle", 35}, {"penumbra", 8}, {"intensity", 50}};
}

json bendy() {
    json l = spot();
    l["name"] = "b";
    l["type"] = "bendy";
    l["controlPoints"] = {{1.5, 0, 0}, {3, 0, 0}, {4.2, 0, 0.6}, {4.8, 0, 1.9}};
    l["radii"] = {0, 0.8, 1.6, 1.9, 2.2};
    l["colors"] = {{1, 1, 1}, {1, 0.9, 0.8}, {1, 1, 1}, {0.5, 0.5, 1}, {1, 1, 1}};
    return l;
}

struct KeyCase {
    std::string name;
    json light;                  // with "keys"
    std::vector<double> times;   // where to evaluate
    std::string thenType;        // non-empty: set the light's type after its keys (keys it no longer takes)
};

// The times of a case: before the first key, at every key, between neighbours (a quarter, half and
// three quarters, so that uneven spacing shows in the tangents), and after the last.
std::vector<double> timesAround(const json& keys) {
    std::vector<double> ts;
    for (const auto& [prop, ks] : keys.items()) {
        for (size_t i = 0; i < ks.size(); ++i) {
            const double t = ks[i]["t"];
            ts.push_back(t);
            if (i + 1 < ks.size()) {
                const double u = ks[i + 1]["t"];
                for (double f : {0.25, 0.5, 0.75, 0.999}) ts.push_back(t + (u - t) * f);
            }
        }
        ts.push_back(double(ks.front()["t"]) - 0.7);
        ts.push_back(double(ks.back()["t"]) + 1.3);
    }
    return ts;
}

std::vector<KeyCase> keyCases() {
    std::vector<KeyCase> cases;
    auto add = [&](std::string name, json light, json keys, std::string thenType = "") {
        light["keys"] = keys;
        cases.push_back({std::move(name), std::move(light), timesAround(keys), std::move(thenType)});
    };
    add("scalar, one key", spot(), {{"intensity", {key(1, 80)}}});
    add("scalar, two linear keys", spot(), {{"intensity", {key(0, 10), key(2, 30)}}});
    add("scalar, three linear keys, uneven", spot(), {{"intensity", {key(0, 10), key(0.3, 50), key(2.5, 20)}}});
    add("scalar, five smooth keys, uneven", spot(),
        {{"intensity", {key(0, 10, "smooth"), key(0.5, 40, "smooth"), key(0.7, 35, "smooth"), key(2, 90, "smooth"), key(5, 60, "smooth")}}});
    add("scalar, linear and smooth mixed", spot(),
        {{"intensity", {key(-1, 5, "smooth"), key(0.25, 60), key(1, 20, "smooth"), key(4, 70, "smooth")}}});
    // Catmull-Rom overshoots below 0 between the first two keys: intensity refuses it, so the
    // property keeps its unkeyed value there.
    add("smooth overshoot refused", spot(), {{"intensity", {key(0, 0, "smooth"), key(1, 0, "smooth"), key(1.1, 100, "smooth"), key(3, 0, "smooth")}}});
    add("shadow bias overshoot above its range", spot(), {{"shadowBias", {key(0, 15.5, "smooth"), key(1, 16, "smooth"), key(1.2, 2, "smooth")}}});
    add("vec3, four linear keys, uneven", spot(),
        {{"position", {key(0, {0, 3, 3}), key(0.4, {1, 4, 2}), key(1.9, {-2, 3.5, 2.5}), key(2, {-2, 2, 1})}}});
    add("vec3, three smooth keys", spot(), {{"position", {key(0, {0, 3, 3}, "smooth"), key(1.5, {2, 5, -1}, "smooth"), key(2, {1, 1, 1}, "smooth")}}});
    add("colour, two smooth keys", spot(), {{"color", {key(0, {1, 0.5, 0.25}, "smooth"), key(3, {0.2, 0.9, 1}, "smooth")}}});
    // Interpolated directions are not unit: the server normalises them (in floats).
    add("direction, linear", spot(), {{"direction", {key(0, {1, 0, 0}), key(1, {0, 0, 1}), key(1.5, {0, -1, 0.2})}}});
    add("barn doors, smooth", spot(), {{"barnDoors", {key(0, {90, 90, 90, 90}, "smooth"), key(1, {20, 45, 60, 90}, "smooth"), key(2.2, {70, 10, 0, 30}, "smooth")}}});
    // The cone is applied before the penumbra (keys in path order) and clamps it; a penumbra
    // key wider than the cone at that time is refused.
    add("cone and penumbra", spot(), {{"coneAngle", {key(0, 40), key(2, 10)}}, {"penumbra", {key(0, 5), key(2, 20)}}});
    add("cone clamps the unkeyed penumbra", spot(), {{"coneAngle", {key(0, 30, "smooth"), key(1, 4, "smooth"), key(1.5, 12, "smooth")}}});
    add("chain elements", bendy(),
        {{"cp[2]", {key(0, {3, 0, 0}, "smooth"), key(0.6, {3, 1, -0.5}, "smooth"), key(2, {2.5, -1, 0.5}, "smooth")}},
         {"r[1]", {key(0, 0.8), key(1, 1.4)}},
         {"cpColor[3]", {key(0.5, {0.5, 0.5, 1}), key(1.5, {1, 0.2, 0.1})}}});
    // "r[1]" sorts before "radii": the whole list's keys win where both are keyed.
    add("element and its list keyed", bendy(),
        {{"r[1]", {key(0, 0.8), key(1, 1.4)}}, {"radii", {key(0, {0, 0.8, 1.6, 1.9, 2.2}), key(2, {0.1, 0.2, 0.3, 0.4, 0.5}, "smooth")}}});
    // Chain keys of a light that is no longer a BendyLight are skipped, its other keys are not.
    add("chain keys of a spot light", bendy(), {{"cp[1]", {key(0, {1.5, 0, 0}), key(1, {1.5, 1, 0})}}, {"intensity", {key(0, 1), key(1, 3)}}},
        "spot");
    return cases;
}

// Directions around the light frame's switch from up = +Y to +X past |uL.y| = 0.99, the axes,
// diagonals and a few ordinary ones; not all of unit length (the frame normalises).
std::vector<Vec3> frameDirections() {
    std::vector<Vec3> dirs = {{1, 0, 0}, {-1, 0, 0}, {0, 0, 1}, {0, 0, -1}, {0, 1, 0}, {0, -1, 0},
                              {0.44f, -0.76f, -0.48f}, {0, -0.7071f, -0.7071f}, {1, 1, 1}, {-3, 2, 5}, {0.01f, 0.02f, -0.03f},
                              {1e-4f, 1, 0}, {0, -1, 1e-3f}, {1e-3f, -1, -1e-3f}, {5, 0, 0}, {0.3f, -0.2f, 0.9f}};
    for (double y : {0.98, 0.98999, 0.99001, 0.995, 0.9999}) {
        for (double s : {1.0, -1.0}) {
            const double r = std::sqrt(1 - y * y);
            dirs.push_back({float(r * 0.6), float(s * y), float(-r * 0.8)});
        }
    }
    dirs.push_back({0.1f, 0.99f * 3.f, 0.05f}); // |y| after normalising ~0.9985: +X up
    dirs.push_back({2.f, -0.2f, 0.f});
    dirs.push_back({-0.05f, 7.f, 0.3f}); // |y| ~0.999: +X up
    dirs.push_back({0.7f, 0.7f, -0.14f});
    // |uL.y| exactly 0.99 after normalising (found by search): the rule's tie, where "|y| > 0.99"
    // and "|y| >= 0.99" pick different up vectors.
    dirs.push_back({0.00011685598292388022f, 1.f, 0.14249223470687866f});
    dirs.push_back({0.00011685598292388022f, -1.f, 0.14249223470687866f});
    return dirs;
}

json vecJson(const glm::dvec3& v) { return json{v.x, v.y, v.z}; }

} // namespace

TEST(ProtocolParityCases, WritesKeyframeAndLightFrameCases) {
    json out{{"about", "written by tests/unit/protocol_parity_cases_test.cpp; read by tests/web/parity.test.mjs"},
             {"keyframes", json::array()}, {"lightFrames", json::array()}, {"areaFrames", json::array()}, {"bentCorners", json::array()},
             {"envRotations", json::array()}, {"schema", protocol::schemaJson()}};
    for (const KeyCase& c : keyCases()) {
        auto rig = protocol::rigFromJson(json{{"lights", {c.light}}});
        ASSERT_TRUE(rig.ok()) << c.name << ": " << rig.error().toString();
        if (!c.thenType.empty()) {
            ASSERT_TRUE(protocol::applyChange(rig.value(), {rig->lights[0].name + ".type", c.thenType}).ok()) << c.name;
        }
        json evaluations = json::array();
        for (double t : c.times) {
            rig->time = t;
            const Rig e = protocol::evaluateRig(rig.value());
            evaluations.push_back({{"time", t}, {"light", protocol::toJson(e.lights[0])}});
        }
        out["keyframes"].push_back({{"name", c.name}, {"light", protocol::toJson(rig->lights[0])}, {"evaluations", evaluations}});
    }
    // The cases test what they say, here first: the evaluation is the server's.
    const auto& cases = out["keyframes"];
    auto at = [&](const std::string& name, size_t i) -> const json& {
        for (const auto& c : cases) if (c["name"] == name) return c["evaluations"][i]["light"];
        ADD_FAILURE() << "no case " << name;
        return cases[0]["light"];
    };
    // "scalar, two linear keys": t = 0 (a key), 0.5, 1 (halfway: 20), ...
    EXPECT_FLOAT_EQ(at("scalar, two linear keys", 0)["intensity"].get<float>(), 10.f);
    EXPECT_FLOAT_EQ(at("scalar, two linear keys", 2)["intensity"].get<float>(), 20.f);
    // The overshoot (t = 0.5, between 0 and 1) is refused: the unkeyed 50 stays.
    EXPECT_FLOAT_EQ(at("smooth overshoot refused", 2)["intensity"].get<float>(), 50.f);
    // A spot light keeps its chain but not its chain's keys.
    EXPECT_FLOAT_EQ(at("chain keys of a spot light", 2)["controlPoints"][0][1].get<float>(), 0.f);

    for (const Vec3& d : frameDirections()) {
        Light l;
        l.direction = d;
        glm::dvec3 u, v, w;
        lightFrame(l, u, v, w);
        if (d[2] == 0.14249223470687866f) {
            EXPECT_EQ(std::abs(u.y), 0.99) << "the tie case is not at the tie";
        }
        EXPECT_NEAR(glm::dot(u, v), 0, 1e-12);
        EXPECT_NEAR(glm::dot(u, w), 0, 1e-12);
        EXPECT_NEAR(glm::length(glm::cross(w, u) - v), 0, 1e-12);
        out["lightFrames"].push_back({{"direction", d}, {"uL", vecJson(u)}, {"vL", vecJson(v)}, {"wL", vecJson(w)}});
        // The emitter's right and up at a few rolls (client/web/area.js areaFrame draws the outline
        // and places the roll handle with them).
        for (double roll : {0.0, 25.0, -90.0, 200.0}) {
            const auto a = lightmath::areaFrame<double>(glm::dvec3(1, 2, 3), glm::dvec3(d[0], d[1], d[2]), roll,
                                                       glm::dvec2(2, 1), false);
            EXPECT_NEAR(glm::dot(a.right, a.up), 0, 1e-12);
            EXPECT_NEAR(glm::dot(a.right, a.normal), 0, 1e-12);
            out["areaFrames"].push_back({{"direction", d}, {"roll", roll}, {"normal", vecJson(a.normal)},
                                         {"right", vecJson(a.right)}, {"up", vecJson(a.up)}});
            // A bent area light's corner chains in world space (dfb::bentAreaCorner, as the engine
            // builds its BendyLights; client/web/area.js cornerChains draws them).
            Light b;
            b.name = "b";
            b.type = LightType::BentArea;
            b.position = {1.f, 2.f, 3.f};
            b.direction = d;
            b.rollDeg = float(roll);
            b.areaSize = {2.f, 1.f};
            makeStraightCorners(b, 3.f, 1);
            for (size_t i = 0; i < b.cornerPoints.size(); ++i) b.cornerPoints[i] = {b.cornerPoints[i][0], 0.25f * float(i), -0.5f + 0.125f * float(i)};
            json corners = json::array();
            for (int c = 0; c < BENT_AREA_CORNERS; ++c) {
                const auto ch = chainFromLight<double>(bentAreaCorner(b, c));
                json pts = json::array();
                for (int i = 0; i <= 2 * ch.segments; ++i) pts.push_back(vecJson(ch.p[i]));
                corners.push_back(pts);
            }
            out["bentCorners"].push_back({{"light", protocol::toJson(b)}, {"corners", corners}});
        }
    }

    // An environment light's map turned (lightmath::envRotation of lightmath::envDirection):
    // client/web/envgizmo.js draws the gizmo's equator, meridian and centre handle with them.
    for (const std::array<float, 3> rot : {std::array<float, 3>{0, 0, 0}, {90, 0, 0}, {-35, 20, 0}, {0, -60, 45}, {170, 80, -120},
                                           {-360, 360, 10}, {12.5f, -89, 200}}) {
        const glm::dmat3 R = lightmath::envRotation(rot);
        json dirs = json::array();
        for (const auto& [u, v] : {std::pair{0.5, 0.5}, {0.0, 0.5}, {0.25, 0.3}, {0.8, 0.9}, {0.5, 0.0}, {0.1, 0.7}}) {
            dirs.push_back({{"u", u}, {"v", v}, {"world", vecJson(R * lightmath::envDirection(u, v))}});
        }
        out["envRotations"].push_back({{"rotation", {rot[0], rot[1], rot[2]}}, {"directions", dirs}});
    }

    for (const auto& [path, j] : {std::pair{CASES, out}, std::pair{SCHEMA, protocol::schemaJson()}}) {
        std::ofstream f(path);
        ASSERT_TRUE(f) << "cannot write " << path;
        f << j.dump(1) << "\n";
        ASSERT_TRUE(f.good()) << "cannot write " << path;
    }
}
