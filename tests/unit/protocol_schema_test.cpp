// The rig schema (protocol/Schema.h) is the one source of truth for the rig's properties: the
// docs table is generated from it, every row validates what it claims, and the cache keys the
// engine derives from it tell every row's edits apart.

#include "support/SchemaEdits.h"

#include <dfb/protocol/Codec.h>
#include <dfb/protocol/DragModes.h>
#include <dfb/protocol/Schema.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

using namespace dfb;
using namespace dfb::protocol;
using json = nlohmann::json;

namespace {

const std::string DOCS = DFB_SOURCE_DIR "/docs/protocol.md";
const std::string BEGIN = "<!-- schema:properties:begin -->\n", END = "<!-- schema:properties:end -->";

bool editable(const Property& p) { return !p.readOnly && p.type != PropType::Keys; }

Light lightOfType(LightType t) {
    Light l;
    l.name = "l";
    if (t == LightType::Bendy) makeStraightChain(l, 3.f, 2);
    if (t == LightType::BentArea) makeStraightCorners(l, 3.f, 2);
    l.type = t;
    return l;
}

// docs/protocol.md between `begin` and `end` equals `table` (DFB_UPDATE_DOCS=1 writes it).
void expectDocsTable(const std::string& begin, const std::string& end, const std::string& table, const char* what) {
    std::ifstream in(DOCS);
    ASSERT_TRUE(in) << DOCS;
    std::stringstream ss;
    ss << in.rdbuf();
    std::string text = ss.str();
    const size_t b = text.find(begin), e = text.find(end);
    ASSERT_NE(b, std::string::npos) << "docs/protocol.md lacks " << begin;
    ASSERT_NE(e, std::string::npos) << "docs/protocol.md lacks " << end;
    if (std::getenv("DFB_UPDATE_DOCS")) {
        text = text.substr(0, b + begin.size()) + table + text.substr(e);
        std::ofstream(DOCS) << text;
        return;
    }
    EXPECT_EQ(text.substr(b + begin.size(), e - b - begin.size()), table)
        << "docs/protocol.md's " << what << " differs: run DFB_UPDATE_DOCS=1 build/tests/protocol_schema_test";
}

} // namespace

TEST(Schema, DocsPropertyTableIsGeneratedFromTheSchema) {
    expectDocsTable(BEGIN, END, markdownTable(), "property table (from the schema)");
}

// The drag modes (dfb/protocol/DragModes.h): every enumerator has one row, names and shortcuts
// are unique (the browser binds the shortcuts), the schema lists them, and docs/protocol.md's
// table is generated from them.
TEST(Schema, DragModesAreOneTableAndTheDocsShowIt) {
    std::set<std::string> names, keys;
    for (int m = 0; m <= int(DragMode::DiffuseMove); ++m) {
        EXPECT_EQ(int(dragModeInfo(DragMode(m)).mode), m);
    }
    for (const DragModeInfo& m : dragModes()) {
        EXPECT_TRUE(names.insert(m.name).second) << m.name;
        EXPECT_TRUE(keys.insert(m.shortcut).second) << m.shortcut;
        EXPECT_EQ(std::string(m.shortcut).size(), 1u);
        auto parsed = parseDragMode(m.name);
        ASSERT_TRUE(parsed.ok());
        EXPECT_EQ(parsed.value(), m.mode);
        EXPECT_NE(m.lights, 0u);
    }
    // The browser's own shortcuts (client/web/main.js) are not taken.
    for (const char* k : {"f", "h", "k", "1"}) EXPECT_EQ(keys.count(k), 0u) << k;
    EXPECT_EQ(schemaJson()["dragModes"].size(), dragModes().size());
    EXPECT_FALSE(parseDragMode("Shadow").ok());

    expectDocsTable("<!-- drag-modes:begin -->\n", "<!-- drag-modes:end -->", dragModesMarkdown(),
                    "drag-mode table (from DragModes.cpp)");
}

TEST(Schema, ToJsonWritesExactlyTheRowsWithValuesAndTheyRoundTrip) {
    for (LightType t : {LightType::Spot, LightType::Point, LightType::Bendy, LightType::Directional, LightType::Area,
                            LightType::BentArea}) {
        Light l = lightOfType(t);
        l.cookie = "c.png";
        l.include = {1};
        l.exclude = {2};
        const json j = toJson(l);
        std::set<std::string> rows;
        for (const Property& p : lightProperties())
            if (p.get && (!p.present || p.present(l))) rows.insert(p.path);
        std::set<std::string> written;
        for (auto it = j.begin(); it != j.end(); ++it) written.insert(it.key());
        EXPECT_EQ(written, rows) << lightTypeName(t);
        Rig rig;
        rig.lights = {l};
        auto back = rigFromJson(toJson(rig));
        ASSERT_TRUE(back.ok()) << back.error().toString();
        EXPECT_EQ(toJson(back->lights[0]), j) << lightTypeName(t);
    }
}

TEST(Schema, EveryRowRefusesWrongTypesAndOutOfRangeValuesNamingThePath) {
    for (const Property& p : lightProperties()) {
        if (!editable(p) || p.type == PropType::String) continue;
        SCOPED_TRACE(p.path);
        for (LightType t : {LightType::Spot, LightType::Point, LightType::Bendy, LightType::Directional, LightType::Area,
                            LightType::BentArea}) {
            if (!(p.appliesTo & (1u << unsigned(t)))) continue;
            Rig rig;
            rig.lights = {lightOfType(t)};
            std::string path = std::string("l.") + p.path;
            if (*p.indexOf) path.replace(path.find("[]"), 2, "[1]");
            std::vector<json> bad = {json("x"), json::object()};
            // Beyond a bound by more than a float's rounding (1e12 + 1 is stored as 1e12: in range).
            const double over = std::max(1.0, 1e-3 * std::abs(p.max));
            if (p.type == PropType::Number || p.type == PropType::Integer) bad.insert(bad.end(), {p.min - 1, p.max + over, json()});
            if (p.type == PropType::Vec3 || p.type == PropType::Color) bad.push_back(json{p.min - 1, 0, 0});
            for (const json& v : bad) {
                const Rig before = rig;
                auto s = applyChange(rig, {path, v});
                ASSERT_FALSE(s.ok()) << path << " = " << v.dump() << " was accepted";
                EXPECT_NE(s.error().message.find(path), std::string::npos) << s.error().message;
                EXPECT_EQ(toJson(rig), toJson(before)) << "a refused edit changed the rig";
            }
        }
    }
}

// A value at a row's bound is stored as a 32-bit float; the rig written back must be accepted again
// (a size of 1e-4 is kept as 9.9999997e-5: compared as double it fell below its own minimum).
TEST(Schema, ValuesAtTheBoundsSurviveARoundTripOfTheRig) {
    for (const Property& p : lightProperties()) {
        if (!editable(p) || p.type != PropType::Number || *p.indexOf || (p.min == 0 && p.max == 0)) continue;
        for (LightType t : {LightType::Spot, LightType::Point, LightType::Bendy, LightType::Directional, LightType::Area,
                            LightType::BentArea}) {
            if (!(p.appliesTo & (1u << unsigned(t)))) continue;
            for (double bound : {p.min, p.max}) {
                SCOPED_TRACE(std::string(p.path) + " = " + json(bound).dump() + " on " + lightTypeName(t));
                Rig rig;
                rig.lights = {lightOfType(t)};
                if (std::string(p.path) == "penumbra") rig.lights[0].coneAngleDeg = 85.f;
                if (!applyChange(rig, {std::string("l.") + p.path, bound}).ok()) continue; // e.g. penumbra above the cone
                auto back = rigFromJson(toJson(rig));
                ASSERT_TRUE(back.ok()) << back.error().toString();
                EXPECT_EQ(toJson(back.value()), toJson(rig));
            }
        }
    }
    Rig rig;
    rig.lights = {lightOfType(LightType::Area)};
    ASSERT_TRUE(applyChange(rig, {"l.size", json{1e-4, 1e-4}}).ok());
    auto back = rigFromJson(toJson(rig));
    ASSERT_TRUE(back.ok()) << back.error().toString();
}

TEST(Schema, KeyframableRowsTakeKeysAndTheOthersRefuseThem) {
    std::mt19937 rng(7);
    for (const Property& p : lightProperties()) {
        if (!editable(p) || (!p.get && !*p.indexOf)) continue;
        SCOPED_TRACE(p.path);
        const LightType t = (p.appliesTo & APPLIES_BENDY)       ? LightType::Bendy
                            : (p.appliesTo & APPLIES_SPOT)      ? LightType::Spot
                            : (p.appliesTo & APPLIES_AREA)      ? LightType::Area
                                                                : LightType::BentArea;
        Rig rig;
        rig.lights = {lightOfType(t)};
        auto edit = test::randomEdit(p, rig.lights[0], rng, {});
        if (!edit) continue;
        auto s = applyChange(rig, {"l.key", json{{"path", edit->first}, {"t", 1.0}, {"value", edit->second}}});
        if (p.keyframable) {
            EXPECT_TRUE(s.ok()) << s.error().toString();
        } else {
            EXPECT_FALSE(s.ok()) << edit->first << " took a key";
        }
    }
}

TEST(Schema, EveryRowsEditChangesTheCacheKeysItsRowNames) {
    std::mt19937 rng(11);
    test::SchemaEditOptions opt;
    opt.objectCount = 4;
    opt.cookies = {"a.png", "b.png"};
    for (const Property& p : lightProperties()) {
        if (!editable(p) || std::string(p.path) == "name" || std::string(p.path) == "type") continue;
        for (LightType t : {LightType::Spot, LightType::Point, LightType::Bendy, LightType::Directional, LightType::Area,
                            LightType::BentArea}) {
            if (!(p.appliesTo & (1u << unsigned(t)))) continue;
            SCOPED_TRACE(std::string(p.path) + " on " + lightTypeName(t));
            Rig rig;
            rig.lights = {lightOfType(t)};
            rig.lights[0].coneAngleDeg = 30.f;
            const Light before = rig.lights[0];
            // An edit that changes the value (a few tries: a random value may equal the old one).
            for (int tries = 0; tries < 20 && toJson(rig.lights[0]) == toJson(before); ++tries) {
                auto edit = test::randomEdit(p, rig.lights[0], rng, opt);
                ASSERT_TRUE(edit);
                if (std::string(p.path) == "coneAngle") edit->second = 41.0; // across a shadow-frustum step
                ASSERT_TRUE(applyChange(rig, {"l." + edit->first, edit->second}).ok());
            }
            const Light& after = rig.lights[0];
            ASSERT_NE(toJson(after), toJson(before)) << "no edit changed the value";
            EXPECT_EQ(sameInputs(before, after, Invalidates::Shadow), p.invalidates < Invalidates::Shadow);
            EXPECT_EQ(sameInputs(before, after, Invalidates::Shade), p.invalidates < Invalidates::Shade);
            EXPECT_EQ(sameInputs(before, after, Invalidates::Scale), p.invalidates < Invalidates::Scale);
        }
    }
    // A spot's cone inside one 5-degree shadow-frustum step re-shades but keeps its shadow map.
    Light a = lightOfType(LightType::Spot), b = a;
    a.coneAngleDeg = 31.f;
    b.coneAngleDeg = 32.f;
    EXPECT_TRUE(sameInputs(a, b, Invalidates::Shadow));
    EXPECT_FALSE(sameInputs(a, b, Invalidates::Shade));
    a.type = b.type = LightType::Bendy;
    makeStraightChain(a, 3.f, 2);
    b.controlPoints = a.controlPoints, b.radii = a.radii, b.colors = a.colors;
    EXPECT_FALSE(sameInputs(a, b, Invalidates::Shadow)) << "a BendyLight's deformed map follows the exact cone";
}

TEST(Schema, ServedJsonListsEveryRowWithItsRangeAndDefault) {
    const json s = schemaJson();
    EXPECT_EQ(s["schema"], 1);
    ASSERT_EQ(s["light"].size(), lightProperties().size());
    ASSERT_EQ(s["rig"].size(), rigProperties().size());
    const Light def;
    for (const json& row : s["light"]) {
        std::string path = row["path"].get<std::string>();
        if (path.ends_with("[]")) path.replace(path.size() - 2, 2, "[1]"); // an element row: any index
        const Property* p = findLightProperty(path);
        ASSERT_NE(p, nullptr) << row.dump();
        if (row.contains("default")) {
            EXPECT_EQ(row["default"], p->get(def)) << p->path;
        }
        EXPECT_FALSE(row["appliesTo"].empty()) << p->path;
    }
    EXPECT_EQ(s["light"][6]["path"], "intensity");
    EXPECT_EQ(s["light"][6]["max"], 1e12);
    EXPECT_EQ(s["rig"][0]["default"], 0.0);
}

TEST(Schema, PathsAreCheckedAsTheCommandLineTypesThem) {
    EXPECT_TRUE(checkPropertyPath("key.intensity").ok());
    EXPECT_TRUE(checkPropertyPath("exposure").ok());
    EXPECT_TRUE(checkPropertyPath("bendy.cp[3]").ok());
    EXPECT_FALSE(checkPropertyPath("key.intensty").ok());
    EXPECT_FALSE(checkPropertyPath("key.warning").ok()) << "read-only";
    EXPECT_FALSE(checkPropertyPath("key.cp[x]").ok());
    auto c = parseAssignment("key.intensty=5");
    ASSERT_FALSE(c.ok());
    EXPECT_NE(c.error().message.find("intensty"), std::string::npos) << c.error().message;
    int index = 0;
    EXPECT_EQ(findLightProperty("cp[]", &index), nullptr);
    EXPECT_EQ(index, -2);
    EXPECT_EQ(findLightProperty("cp[12]", &index)->path, std::string("cp[]"));
    EXPECT_EQ(index, 12);
}
