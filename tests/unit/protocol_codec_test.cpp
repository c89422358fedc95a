// Protocol codec: rig values are validated, edits are all-or-nothing, frame headers round-trip.
// (The v1 messages: protocol_messages_test.cpp.)

#include <dfb/protocol/Codec.h>

#include <gtest/gtest.h>

using namespace dfb;
using namespace dfb::protocol;
using json = nlohmann::json;

namespace {
Rig testRig() { return defaultRig({-1, 0, -1}, {1, 1, 1}); }
} // namespace

TEST(Codec, AppliesChangesAndValidatesValues) {
    Rig rig = testRig();
    ASSERT_TRUE(applyChange(rig, {"key.intensity", 500}).ok());
    EXPECT_FLOAT_EQ(rig.find("key")->intensityCd, 500.f);
    ASSERT_TRUE(applyChange(rig, {"key.position", {1, 2, 3}}).ok());
    EXPECT_EQ(rig.find("key")->position, (Vec3{1, 2, 3}));
    ASSERT_TRUE(applyChange(rig, {"key.direction", {0, -2, 0}}).ok());
    EXPECT_EQ(rig.find("key")->direction, (Vec3{0, -1, 0})); // normalised
    ASSERT_TRUE(applyChange(rig, {"exposure", 1.5}).ok());
    EXPECT_FLOAT_EQ(rig.exposureStops, 1.5f);

    const Rig before = rig;
    for (const Change& bad : {Change{"key.intensity", -1}, Change{"key.intensity", "bright"},
                              Change{"key.position", {1, 2}}, Change{"key.coneAngle", 120},
                              Change{"key.direction", {0, 0, 0}}, Change{"nobody.intensity", 1},
                              Change{"key.unknown", 1}, Change{"key", 1}, Change{"key.shadowMapSize", 1000},
                              Change{"key.color", {1, nlohmann::json(nullptr), 1}}}) {
        auto s = applyChange(rig, bad);
        EXPECT_FALSE(s.ok()) << bad.path << " = " << bad.value.dump();
        if (!s.ok()) {
            EXPECT_NE(s.error().message.find(bad.path.substr(0, 3)), std::string::npos) << s.error().message;
        }
    }
    EXPECT_EQ(toJson(rig), toJson(before)); // nothing changed
}

TEST(Codec, PointLightsCookiesBarnDoorsAndShadowFilter) {
    Rig rig = testRig();
    ASSERT_TRUE(applyChanges(rig, {{"key.type", "point"}, {"key.barnDoors", {10, 20, 30, 90}}, {"key.shadowFilter", 3},
                                   {"key.cookie", "gobos/window.png"}})
                    .ok());
    const Light& l = *rig.find("key");
    EXPECT_EQ(l.type, LightType::Point);
    EXPECT_EQ(l.barnDoorsDeg, (std::array<float, 4>{10, 20, 30, 90}));
    EXPECT_EQ(l.shadowFilter, 3);
    EXPECT_EQ(l.cookie, "gobos/window.png");
    auto back = rigFromJson(toJson(rig));
    ASSERT_TRUE(back.ok()) << back.error().toString();
    EXPECT_EQ(toJson(back.value()), toJson(rig));
    const Rig before = rig;
    for (const Change& bad : {Change{"key.type", "panel"}, Change{"key.barnDoors", {10, 20, 30}}, Change{"key.barnDoors", {10, 20, 30, 91}},
                              Change{"key.shadowFilter", 5}, Change{"key.shadowFilter", 1.5}, Change{"key.cookie", "/etc/passwd"},
                              Change{"key.cookie", "../secret.png"}, Change{"key.cookie", 3}}) {
        auto s = applyChange(rig, bad);
        EXPECT_FALSE(s.ok()) << bad.path << " = " << bad.value.dump();
        if (!s.ok()) {
            EXPECT_NE(s.error().message.find(bad.path), std::string::npos) << s.error().message;
        }
    }
    EXPECT_EQ(toJson(rig), toJson(before));
}

TEST(Codec, ViewTransform) {
    Rig rig = testRig();
    EXPECT_EQ(rig.viewTransform, ViewTransform::Srgb);
    ASSERT_TRUE(applyChange(rig, {"viewTransform", "filmic"}).ok());
    EXPECT_EQ(rig.viewTransform, ViewTransform::Filmic);
    auto back = rigFromJson(toJson(rig));
    ASSERT_TRUE(back.ok()) << back.error().toString();
    EXPECT_EQ(back->viewTransform, ViewTransform::Filmic);
    auto bad = applyChange(rig, {"viewTransform", "agx"});
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().message.find("viewTransform"), std::string::npos);
    EXPECT_EQ(rig.viewTransform, ViewTransform::Filmic);
}

TEST(Codec, EditsAreAllOrNothing) {
    Rig rig = testRig();
    const float before = rig.find("key")->intensityCd;
    auto s = applyChanges(rig, {{"key.intensity", 1234}, {"key.coneAngle", 999}});
    EXPECT_FALSE(s.ok());
    EXPECT_FLOAT_EQ(rig.find("key")->intensityCd, before);
}

TEST(Codec, RigJsonRoundTrips) {
    Rig rig = testRig();
    rig.version = 42;
    auto back = rigFromJson(toJson(rig));
    ASSERT_TRUE(back.ok()) << back.error().toString();
    EXPECT_EQ(toJson(back.value()), toJson(rig));
    auto bad = rigFromJson(nlohmann::json{{"lights", {{{"name", "a"}}, {{"name", "a"}}}}});
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().message.find("duplicate"), std::string::npos);
}

TEST(Codec, ParsesCommandLineAssignments) {
    auto a = parseAssignment("key.position=1,2.5,-3");
    ASSERT_TRUE(a.ok());
    EXPECT_EQ(a->value, nlohmann::json({1, 2.5, -3}));
    auto b = parseAssignment("key.intensity=500");
    ASSERT_TRUE(b.ok());
    EXPECT_EQ(b->value, 500);
    auto c = parseAssignment("key.shadow=false");
    ASSERT_TRUE(c.ok());
    EXPECT_EQ(c->value, false);
    EXPECT_FALSE(parseAssignment("novalue").ok());
    EXPECT_FALSE(parseAssignment("key.position=1,x,3").ok());
}

TEST(Codec, FrameHeaderRoundTripsAndRejectsGarbage) {
    FrameHeader h;
    h.encoding = Encoding::Png;
    h.frameNumber = 0x0102030405060708ull;
    h.rigVersion = 99;
    h.width = 1920;
    h.height = 1080;
    uint8_t buf[FRAME_HEADER_BYTES];
    writeFrameHeader(h, buf);
    auto r = readFrameHeader(buf, sizeof buf);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(r->frameNumber, h.frameNumber);
    EXPECT_EQ(r->rigVersion, 99u);
    EXPECT_EQ(r->width, 1920u);
    EXPECT_EQ(r->encoding, Encoding::Png);
    EXPECT_FALSE(readFrameHeader(buf, 10).ok());
    buf[0] = 'X';
    EXPECT_FALSE(readFrameHeader(buf, sizeof buf).ok());
}

TEST(Keyframes, LinearAndSmoothInterpolationOfNumbersAndControlPoints) {
    Rig rig = testRig();
    Light& key = *rig.find("key");
    ASSERT_TRUE(applyChange(rig, {"key.type", "bendy"}).ok());
    // Intensity: linear 0 s -> 10, 2 s -> 30, then smooth to 4 s -> 10.
    ASSERT_TRUE(applyChange(rig, {"key.key", {{"path", "intensity"}, {"t", 0}, {"value", 10}}}).ok());
    ASSERT_TRUE(applyChange(rig, {"key.key", {{"path", "intensity"}, {"t", 2}, {"value", 30}, {"interp", "smooth"}}}).ok());
    ASSERT_TRUE(applyChange(rig, {"key.key", {{"path", "intensity"}, {"t", 4}, {"value", 10}}}).ok());
    // A control point, linear between two positions.
    ASSERT_TRUE(applyChange(rig, {"key.key", {{"path", "cp[2]"}, {"t", 0}, {"value", {2, 0, 0}}}}).ok());
    ASSERT_TRUE(applyChange(rig, {"key.key", {{"path", "cp[2]"}, {"t", 1}, {"value", {2, 1, 0}}}}).ok());
    (void)key;
    auto at = [&](double t) {
        Rig r = rig;
        EXPECT_TRUE(applyChange(r, {"time", t}).ok());
        return evaluateRig(r);
    };
    EXPECT_FLOAT_EQ(at(-1).find("key")->intensityCd, 10.f); // clamped before the first key
    EXPECT_FLOAT_EQ(at(1).find("key")->intensityCd, 20.f);  // linear
    EXPECT_FLOAT_EQ(at(2).find("key")->intensityCd, 30.f);  // through the key
    EXPECT_FLOAT_EQ(at(9).find("key")->intensityCd, 10.f);  // clamped after the last
    // Smooth: symmetric keys 30 -> 10 with neighbours 10 (before) and 10 (after, clamped) give a
    // curve above the straight line's value at the middle (the tangent at 2 s is flat).
    const float smoothMid = at(3).find("key")->intensityCd;
    EXPECT_GT(smoothMid, 20.f);
    EXPECT_LT(smoothMid, 30.f);
    const Vec3 cp = at(0.25).find("key")->controlPoints[1];
    EXPECT_FLOAT_EQ(cp[1], 0.25f);
    // Keys survive the rig's JSON.
    auto back = rigFromJson(toJson(rig));
    ASSERT_TRUE(back.ok()) << back.error().toString();
    EXPECT_EQ(toJson(back.value()), toJson(rig));
    // Bad keys are refused with the reason: a value the property refuses, a non-numeric value.
    EXPECT_FALSE(applyChange(rig, {"key.key", {{"path", "coneAngle"}, {"t", 0}, {"value", 300}}}).ok());
    EXPECT_FALSE(applyChange(rig, {"key.key", {{"path", "name"}, {"t", 0}, {"value", "x"}}}).ok());
    ASSERT_TRUE(applyChange(rig, {"key.unkey", {{"path", "intensity"}, {"t", 2}}}).ok());
    EXPECT_FLOAT_EQ(at(2).find("key")->intensityCd, 10.f); // 0 s -> 10 and 4 s -> 10 remain
}

// Light groups (issue 20 point 4; the rig's `groups`): set as one rig-level change, checked (names,
// duplicates, members that exist, the count limit), written only when there are some, renamed
// with their lights, and a replaced rig (rigFromJson) drops the members it no longer has.
TEST(Codec, LightGroupsAreCheckedFollowRenamesAndSurviveJson) {
    Rig rig = defaultRig({-1, 0, -1}, {1, 1, 1});
    ASSERT_GE(rig.lights.size(), 2u);
    EXPECT_FALSE(protocol::toJson(rig).contains("groups")) << "no groups, no field";
    const json two = json::parse(R"([{"name": "keys", "lights": ["key", "fill", "key"]}, {"name": "fills", "lights": ["fill"]}])");
    ASSERT_TRUE(protocol::applyChanges(rig, {{"groups", two}}).ok());
    ASSERT_EQ(rig.groups.size(), 2u);
    EXPECT_EQ(rig.groups[0].lights, (std::vector<std::string>{"key", "fill"})) << "a repeated member counts once";

    auto refused = [&](const json& v, const std::string& words) {
        Rig copy = rig;
        auto st = protocol::applyChanges(copy, {{"groups", v}});
        ASSERT_FALSE(st.ok()) << v.dump();
        EXPECT_NE(st.error().message.find(words), std::string::npos) << st.error().message;
        EXPECT_EQ(copy.groups, rig.groups) << "nothing changed";
    };
    refused(json::parse(R"([{"name": "a", "lights": ["nobody"]}])"), "groups[0].lights: no light named \"nobody\"");
    refused(json::parse(R"([{"name": "a b", "lights": []}])"), "groups[0].name: a name is 1-64 characters");
    refused(json::parse(R"([{"name": "a", "lights": []}, {"name": "a", "lights": []}])"), "a group named 'a' already exists");
    refused(json::parse(R"([{"name": "a"}])"), "expected {\"name\", \"lights\"}");
    refused(json::parse(R"({"name": "a"})"), "expected an array");
    json many = json::array();
    for (size_t i = 0; i <= MAX_LIGHT_GROUPS; ++i) many.push_back({{"name", "g" + std::to_string(i)}, {"lights", json::array()}});
    refused(many, "at most 64");

    // A rename follows into the groups.
    ASSERT_TRUE(protocol::applyChanges(rig, {{"fill.name", "soft"}}).ok());
    EXPECT_EQ(rig.groups[0].lights, (std::vector<std::string>{"key", "soft"}));
    EXPECT_EQ(rig.groups[1].lights, (std::vector<std::string>{"soft"}));

    // JSON round trip; a rig without "soft" keeps its groups, less that member.
    json j = protocol::toJson(rig);
    auto back = protocol::rigFromJson(j);
    ASSERT_TRUE(back.ok()) << back.error().toString();
    EXPECT_EQ(back->groups, rig.groups);
    j["lights"].erase(1);
    auto without = protocol::rigFromJson(j);
    ASSERT_TRUE(without.ok()) << without.error().toString();
    ASSERT_EQ(without->groups.size(), 2u);
    EXPECT_EQ(without->groups[0].lights, (std::vector<std::string>{"key"}));
    EXPECT_TRUE(without->groups[1].lights.empty());
}
