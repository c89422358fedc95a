// Bounded JSON input (issue 14): depth and size limits enforced while parsing, errors that quote
// a short excerpt of a bad value, and the rig limits. The inputs that crashed the server (a
// value nested 100,000 levels deep) are refused here without building them.

#include <dfb/protocol/Json.h>
#include <dfb/protocol/Messages.h>

#include <gtest/gtest.h>

#include <chrono>

using namespace dfb;
using namespace dfb::protocol;
using json = nlohmann::json;

namespace {
std::string nested(int depth, const std::string& inner = "1") {
    return std::string(size_t(depth), '[') + inner + std::string(size_t(depth), ']');
}
std::string nestedObjects(int depth) {
    std::string s;
    for (int i = 0; i < depth; ++i) s += "{\"a\":";
    s += "1";
    s += std::string(size_t(depth), '}');
    return s;
}
} // namespace

TEST(Json, DepthIsLimitedWhileParsing) {
    auto ok = parseJson(nested(MAX_JSON_DEPTH), 1 << 20, "x");
    ASSERT_TRUE(ok.ok()) << ok.error().toString();
    auto deep = parseJson(nested(MAX_JSON_DEPTH + 1), 1 << 20, "the message");
    ASSERT_FALSE(deep.ok());
    EXPECT_EQ(deep.error().code, ErrorCode::LimitExceeded);
    EXPECT_NE(deep.error().message.find("the message"), std::string::npos) << deep.error().message;
    EXPECT_NE(deep.error().message.find("64 levels"), std::string::npos) << deep.error().message;
    EXPECT_FALSE(parseJson(nestedObjects(MAX_JSON_DEPTH + 1), 1 << 20, "x").ok());
    EXPECT_TRUE(parseJson(nestedObjects(MAX_JSON_DEPTH), 1 << 20, "x").ok());
    // The input that crashed dfb-server: refused at level 65, long before the end.
    const std::string huge = nested(100000);
    const auto t0 = std::chrono::steady_clock::now();
    auto r = parseJson(huge, 1 << 20, "x");
    EXPECT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::LimitExceeded);
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5));
    // Depth is not length: a long flat array is fine.
    std::string flat = "[";
    for (int i = 0; i < 10000; ++i) flat += (i ? ",[1]" : "[1]");
    flat += "]";
    EXPECT_TRUE(parseJson(flat, 1 << 20, "x").ok());
}

TEST(Json, SizeIsLimitedAndBadJsonNamed) {
    auto big = parseJson(std::string(2000, ' ') + "1", 1000, "PUT rig: the body");
    ASSERT_FALSE(big.ok());
    EXPECT_EQ(big.error().code, ErrorCode::LimitExceeded);
    EXPECT_NE(big.error().message.find("1000 bytes"), std::string::npos) << big.error().message;
    auto bad = parseJson("{\"a\": tru}", 1000, "message");
    ASSERT_FALSE(bad.ok());
    EXPECT_EQ(bad.error().code, ErrorCode::Protocol);
    EXPECT_NE(bad.error().message.find("message: not valid JSON"), std::string::npos) << bad.error().message;
    EXPECT_FALSE(parseJson("1 2", 1000, "x").ok()); // one value, nothing after it
    EXPECT_FALSE(parseJson("", 1000, "x").ok());
}

TEST(Json, ExcerptsAreShortAndNeverRecurse) {
    EXPECT_EQ(excerpt(json(12)), "12");
    EXPECT_EQ(excerpt(json("spot")), "\"spot\"");
    const std::string longText(5000, 'x');
    const std::string e = excerpt(json(longText));
    EXPECT_LE(e.size(), 50u);
    EXPECT_EQ(e.substr(e.size() - 3), "...");
    EXPECT_EQ(excerpt(json::array({1, 2, 3})), "an array of 3 values");
    EXPECT_EQ(excerpt(json::object({{"a", 1}})), "an object of 1 member");
    EXPECT_EQ(excerpt(json("\n\x01")), "\"\\n\\u0001\""); // escaped: one line in a log
}

TEST(Json, DeepMessagesAreRefusedWithAShortError) {
    // Each of the crash inputs of issue 14, as the decoder sees them.
    const std::string deep = nested(100000);
    for (const std::string& text :
         {R"({"type":"view","seq":1,"encoding":)" + deep + "}", R"({"type":"view","seq":1,"viewTransform":)" + deep + "}",
          R"({"type":"edit","seq":1,"changes":[{"path":"viewTransform","value":)" + deep + "}]}",
          R"({"type":"edit","seq":1,"changes":[{"path":"key.type","value":)" + deep + "}]}"}) {
        auto m = parseClientMessage(text);
        ASSERT_FALSE(m.ok());
        EXPECT_EQ(m.error().code, ErrorCode::LimitExceeded);
        EXPECT_LT(m.error().message.size(), 200u);
        EXPECT_FALSE(peekSeq(text).has_value());
    }
    // At the limit the value arrives, and the codec's error quotes an excerpt, not the value.
    auto view = parseClientMessage(R"({"type":"view","seq":1,"encoding":)" + nested(MAX_JSON_DEPTH - 1) + "}");
    ASSERT_FALSE(view.ok());
    EXPECT_NE(view.error().message.find("an array of 1 value"), std::string::npos) << view.error().message;
    Rig rig = defaultRig({-1, 0, -1}, {1, 1, 1});
    auto type = applyChange(rig, {"key.type", json::parse(nested(MAX_JSON_DEPTH - 2))});
    ASSERT_FALSE(type.ok());
    EXPECT_LT(type.error().message.size(), 200u) << type.error().message;
}

TEST(Json, ProtocolVersionsOutOfRangeAreRefused) {
    EXPECT_TRUE(parseClientMessage(R"({"type":"hello","protocol":1})").ok());
    for (const char* v : {"4294967297", "-4294967295", "18446744073709551615", "0", "2"}) {
        auto m = parseClientMessage(std::string(R"({"type":"hello","protocol":)") + v + "}");
        ASSERT_FALSE(m.ok()) << v;
        EXPECT_NE(m.error().message.find(v), std::string::npos) << m.error().message;
    }
}

TEST(RigLimits, LightsKeysAndMemoryAreLimited) {
    RigLimits limits;
    limits.imagePixels = 320 * 180;
    Rig rig = defaultRig({-1, 0, -1}, {1, 1, 1});
    ASSERT_TRUE(checkRigLimits(rig, limits).ok());
    Light base = rig.lights[0];
    base.shadowMapSize = 256;
    rig.lights.clear();
    for (size_t i = 0; i < limits.maxLights; ++i) {
        Light l = base;
        l.name = "l" + std::to_string(i);
        rig.lights.push_back(l);
    }
    EXPECT_TRUE(checkRigLimits(rig, limits).ok()) << checkRigLimits(rig, limits).error().toString();
    rig.lights.push_back(base);
    auto over = checkRigLimits(rig, limits);
    ASSERT_FALSE(over.ok());
    EXPECT_EQ(over.error().code, ErrorCode::LimitExceeded);
    EXPECT_NE(over.error().message.find("257 lights"), std::string::npos) << over.error().message;
    EXPECT_NE(over.error().message.find("256"), std::string::npos);
    EXPECT_NE(over.error().message.find("--max-lights"), std::string::npos);

    // Memory: 128 lights with 2048 maps = 2 GiB of shadow maps alone.
    Rig big;
    for (int i = 0; i < 128; ++i) {
        Light l = base;
        l.name = "m" + std::to_string(i);
        l.shadowMapSize = 2048;
        big.lights.push_back(l);
    }
    auto mem = checkRigLimits(big, limits);
    ASSERT_FALSE(mem.ok());
    EXPECT_NE(mem.error().message.find("--max-light-memory-mb"), std::string::npos) << mem.error().message;
    for (auto& l : big.lights) l.shadow = false; // without shadow maps the images alone fit
    EXPECT_TRUE(checkRigLimits(big, limits).ok());
    EXPECT_EQ(lightMemoryBytes(big.lights[0], limits), uint64_t(320 * 180 * 16)); // RGBA32F contribution
    Light point = base;
    point.type = LightType::Point;
    point.shadowMapSize = 512;
    EXPECT_EQ(lightMemoryBytes(point, limits), uint64_t(320 * 180 * 16) + uint64_t(512 * 512 * 4 * 6));

    // Keys of one property.
    Rig keyed = defaultRig({-1, 0, -1}, {1, 1, 1});
    auto& ks = keyed.lights[0].keys["intensity"];
    for (size_t i = 0; i <= limits.maxKeysPerProperty; ++i) ks.push_back({double(i), json(1.0), Interp::Linear});
    auto k = checkRigLimits(keyed, limits);
    ASSERT_FALSE(k.ok());
    EXPECT_NE(k.error().message.find("--max-keys"), std::string::npos) << k.error().message;

    // Control points: the codec's own limit, as limit_exceeded.
    Rig chain = defaultRig({-1, 0, -1}, {1, 1, 1});
    ASSERT_TRUE(applyChange(chain, {"key.type", "bendy"}).ok());
    json pts = json::array();
    for (int i = 0; i < 2 * MAX_BENDY_SEGMENTS + 2; ++i) pts.push_back({0, 0, i + 1});
    auto cp = applyChange(chain, {"key.controlPoints", pts});
    ASSERT_FALSE(cp.ok());
    EXPECT_EQ(cp.error().code, ErrorCode::LimitExceeded);
}

// Error codes read back by name (dfb-client maps a refused WebSocket upgrade's `code` so).
TEST(Json, ErrorCodesRoundTripByName) {
    for (int c = int(ErrorCode::Ok); c <= int(ErrorCode::Moved); ++c) {
        EXPECT_EQ(errorCodeFromString(toString(ErrorCode(c))), ErrorCode(c)) << toString(ErrorCode(c));
    }
    EXPECT_FALSE(errorCodeFromString("no_such_code").has_value());
    EXPECT_STREQ(toString(ErrorCode(int(ErrorCode::Moved) + 1)), "unknown"); // nothing after the last
}

// The rig's floats are written in their shortest form and read back as the same floats.
TEST(Json, ShortestFloatsKeepTheFloat) {
    nlohmann::json j = {{"a", double(0.95f)}, {"b", {double(1e-7f), 3.0, 0.1}}, {"n", 7}};
    shortestFloats(j);
    EXPECT_EQ(j["a"].dump(), "0.95");
    EXPECT_EQ(float(j["b"][0].get<double>()), 1e-7f);
    EXPECT_EQ(j["b"][2].get<double>(), 0.1); // already shortest (not a float's value): kept
    EXPECT_TRUE(j["n"].is_number_integer());
}
