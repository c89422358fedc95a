// The session's annotations (session/Annotations.h): the checks a new one passes through
// (protocol::annotationFromJson, then the shot's bounds and the per-session limit), each refusal
// naming the field and its limit; ids that only grow; resolve and reopen; a store kept on disk
// reloads as it was, with a damaged file skipped and named, and never overwritten by a new one.

#include "session/Annotations.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <unistd.h>

using namespace dfb;
using json = nlohmann::json;

namespace {

protocol::AnnotateMessage shape(const json& j) {
    auto m = protocol::annotationFromJson(j, "annotation");
    EXPECT_TRUE(m.ok()) << (m.ok() ? "" : m.error().message);
    return m.ok() ? m.value() : protocol::AnnotateMessage{};
}

// The refusal of `j` by annotationFromJson, which must name `expected`.
void refused(const json& j, const std::string& expected) {
    auto m = protocol::annotationFromJson(j, "annotation");
    ASSERT_FALSE(m.ok()) << j.dump();
    EXPECT_NE(m.error().message.find(expected), std::string::npos) << j.dump().substr(0, 80) << " -> " << m.error().message;
}

json strokeOf(size_t n) {
    json pts = json::array();
    for (size_t i = 0; i < n; ++i) pts.push_back({double(i % 300), 10.5});
    return json{{"kind", "stroke"}, {"points", pts}};
}

} // namespace

TEST(Annotations, ShapesAreCheckedFieldByField) {
    shape({{"kind", "pin"}, {"points", {{10, 20}}}, {"text", "too dark"}});
    shape({{"kind", "pin"}, {"points", {{0, 0}}}, {"text", std::string(2000, 'x')}, {"color", "#FFaa00"}});
    shape(strokeOf(2));
    shape(strokeOf(2000));
    // 2000 characters of three bytes each: the limit counts characters.
    std::string wide;
    for (int i = 0; i < 2000; ++i) wide += "\xe2\x82\xac";
    shape({{"kind", "pin"}, {"points", {{1, 1}}}, {"text", wide}});
    EXPECT_EQ(shape({{"kind", "pin"}, {"points", {{1, 1}}}, {"text", "a"}, {"color", "#FFAA00"}}).color, "#ffaa00");

    refused({{"kind", "circle"}, {"points", {{1, 1}}}}, "annotation.kind: expected \"pin\" or \"stroke\"");
    refused({{"kind", "pin"}, {"points", {{1, 1}}}}, "annotation.text: a pin needs a comment (1..2000 characters)");
    refused({{"kind", "pin"}, {"points", {{1, 1}, {2, 2}}}, {"text", "a"}}, "annotation.points: a pin has exactly 1 point, not 2");
    refused(strokeOf(1), "annotation.points: a stroke has 2..2000 points, not 1");
    refused(strokeOf(2001), "a stroke has 2..2000 points, not 2001");
    refused({{"kind", "pin"}, {"points", {{1, "a"}}}, {"text", "a"}}, "annotation.points[0]:");
    refused({{"kind", "pin"}, {"points", {{1}}}, {"text", "a"}}, "is not a pixel [x, y] of finite numbers");
    refused({{"kind", "pin"}, {"points", {{1, 1}}}, {"text", std::string(2001, 'x')}}, "annotation.text: 2001 characters, more than the 2000 allowed");
    refused({{"kind", "pin"}, {"points", {{1, 1}}}, {"text", "a\x01"}}, "annotation.text: control characters");
    refused({{"kind", "pin"}, {"points", {{1, 1}}}, {"text", "a"}, {"color", "red"}}, "annotation.color: \"red\" is not a color \"#rrggbb\"");
    refused({{"kind", "pin"}, {"points", {{1, 1}}}, {"text", "a"}, {"size", 3}}, "annotation: unknown field 'size'");
    // Not finite: JSON has no NaN, but a huge exponent parses to infinity.
    auto inf = protocol::parseClientMessage(R"({"type":"annotate","seq":1,"kind":"pin","points":[[1e999,1]],"text":"a"})");
    EXPECT_FALSE(inf.ok());

    // The message: type and seq besides the fields, and back through encode.
    auto m = protocol::parseClientMessage(R"({"type":"annotate","seq":7,"kind":"pin","points":[[3.5,4]],"text":"here","color":"#00ff00"})");
    ASSERT_TRUE(m.ok()) << m.error().message;
    const auto& a = std::get<protocol::AnnotateMessage>(m.value());
    EXPECT_EQ(a.seq, 7u);
    EXPECT_EQ(a.points[0][0], 3.5);
    EXPECT_EQ(protocol::encode(a), R"({"color":"#00ff00","kind":"pin","points":[[3.5,4.0]],"seq":7,"text":"here","type":"annotate"})");
    auto noSeq = protocol::parseClientMessage(R"({"type":"annotate","kind":"pin","points":[[3.5,4]],"text":"x"})");
    ASSERT_FALSE(noSeq.ok());
    EXPECT_NE(noSeq.error().message.find("annotate.seq"), std::string::npos);
    auto typo = protocol::parseClientMessage(R"({"type":"annotate","seq":1,"kind":"pin","points":[[1,1]],"txt":"x"})");
    ASSERT_FALSE(typo.ok());
    EXPECT_NE(typo.error().message.find("annotate: unknown field 'txt'"), std::string::npos) << typo.error().message;
}

TEST(Annotations, BoundsLimitsResolveAndIds) {
    auto store = Annotations::open({});
    ASSERT_TRUE(store.ok());
    Annotations& s = *store.value();
    EXPECT_FALSE(s.persistent());
    const auto pin = shape({{"kind", "pin"}, {"points", {{320, 180}}}, {"text", "corner"}});
    auto first = s.add(pin, 320, 180, 5, "alice");
    ASSERT_TRUE(first.ok()) << first.error().message;
    EXPECT_EQ((*first)["id"], 1);
    EXPECT_EQ((*first)["rigVersion"], 5);
    EXPECT_EQ((*first)["by"], "alice");
    EXPECT_EQ((*first)["resolved"], false);
    EXPECT_EQ((*first)["time"].get<std::string>().size(), 20u) << (*first)["time"]; // 2026-12-05T19:47:41Z

    auto outside = s.add(shape({{"kind", "pin"}, {"points", {{320.5, 10}}}, {"text", "x"}}), 320, 180, 5, "a");
    ASSERT_FALSE(outside.ok());
    EXPECT_EQ(outside.error().code, ErrorCode::InvalidValue);
    EXPECT_NE(outside.error().message.find("annotation.points[0]: [320.5, 10.0] is outside the 320x180 shot"), std::string::npos)
        << outside.error().message;
    auto stroke = shape(strokeOf(5));
    stroke.points[3] = {-1, 3};
    auto neg = s.add(stroke, 320, 180, 5, "a");
    ASSERT_FALSE(neg.ok());
    EXPECT_NE(neg.error().message.find("annotation.points[3]"), std::string::npos) << neg.error().message;

    auto r = s.setResolved(1, true, "bob");
    ASSERT_TRUE(r.ok());
    EXPECT_EQ((*r)["resolvedBy"], "bob");
    EXPECT_EQ(s.setResolved(1, true, "carol").value()["resolvedBy"], "bob") << "the first resolver stays";
    auto reopened = s.setResolved(1, false, "carol");
    ASSERT_TRUE(reopened.ok());
    EXPECT_EQ((*reopened)["resolved"], false);
    EXPECT_FALSE(reopened->contains("resolvedBy"));
    EXPECT_EQ(s.setResolved(9, true, "x").error().code, ErrorCode::MissingData);

    for (size_t i = 1; i < Annotations::MAX_ANNOTATIONS; ++i) ASSERT_TRUE(s.add(pin, 320, 180, 5, "a").ok());
    auto over = s.add(pin, 320, 180, 5, "a");
    ASSERT_FALSE(over.ok());
    EXPECT_EQ(over.error().code, ErrorCode::LimitExceeded);
    EXPECT_NE(over.error().message.find("1000 annotations"), std::string::npos) << over.error().message;
    ASSERT_TRUE(s.remove(1000).ok());
    EXPECT_EQ(s.remove(1000).error().code, ErrorCode::MissingData);
    auto next = s.add(pin, 320, 180, 6, "a");
    ASSERT_TRUE(next.ok());
    EXPECT_EQ((*next)["id"], 1001) << "ids only grow";
    EXPECT_EQ(s.list().size(), Annotations::MAX_ANNOTATIONS);
    EXPECT_EQ(s.list()[0]["id"], 1);
}

TEST(Annotations, PointsOfTheWholeSessionAreBounded) {
    // The whole list goes to every client on every change: its points are bounded together.
    auto store = Annotations::open({});
    Annotations& s = *store.value();
    const auto full = shape(strokeOf(protocol::MAX_ANNOTATION_POINTS));
    const size_t strokes = Annotations::MAX_TOTAL_POINTS / protocol::MAX_ANNOTATION_POINTS;
    for (size_t i = 0; i < strokes; ++i) ASSERT_TRUE(s.add(full, 320, 180, 1, "a").ok()) << i;
    auto over = s.add(shape(strokeOf(2)), 320, 180, 1, "a");
    ASSERT_FALSE(over.ok());
    EXPECT_EQ(over.error().code, ErrorCode::LimitExceeded);
    EXPECT_NE(over.error().message.find("hold 200000 points, and 2 more would pass the 200000"), std::string::npos) << over.error().message;
    ASSERT_TRUE(s.remove(1).ok());
    EXPECT_TRUE(s.add(shape(strokeOf(2)), 320, 180, 1, "a").ok()) << "a deleted stroke's points are free again";
}

TEST(Annotations, KeptOnDiskAndDamagedFilesSkipped) {
    const auto dir = std::filesystem::temp_directory_path() / ("dfb_annotations_unit_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    {
        auto store = Annotations::open(dir);
        ASSERT_TRUE(store.ok()) << store.error().message;
        Annotations& s = *store.value();
        EXPECT_TRUE(s.persistent());
        ASSERT_TRUE(s.add(shape({{"kind", "pin"}, {"points", {{1.25, 2}}}, {"text", "eins"}, {"color", "#112233"}}), 320, 180, 3, "a").ok());
        ASSERT_TRUE(s.add(shape(strokeOf(3)), 320, 180, 4, "b").ok());
        ASSERT_TRUE(s.add(shape({{"kind", "pin"}, {"points", {{5, 5}}}, {"text", "drei"}}), 320, 180, 4, "c").ok());
        ASSERT_TRUE(s.setResolved(2, true, "d").ok());
        ASSERT_TRUE(s.remove(3).ok());
        EXPECT_FALSE(std::filesystem::exists(dir / "3.json"));
    }
    const json before = Annotations::open(dir).value()->list();
    ASSERT_EQ(before.size(), 2u);
    EXPECT_EQ(before[0]["color"], "#112233");
    EXPECT_EQ(before[0]["points"], json::parse("[[1.25, 2.0]]"));
    EXPECT_EQ(before[1]["resolvedBy"], "d");

    // Damage: a cut record, one whose id disagrees with its file, one breaking the protocol's
    // limits, a stray name. Each is skipped and named, the good ones kept.
    std::ofstream(dir / "7.json") << R"({"id": 7, "kind": "pin", "points": )";
    json wrongId = before[0];
    wrongId["id"] = 2;
    std::ofstream(dir / "8.json") << wrongId.dump();
    json tooLong = before[0];
    tooLong["id"] = 9;
    tooLong["text"] = std::string(2001, 'x');
    std::ofstream(dir / "9.json") << tooLong.dump();
    std::ofstream(dir / "notes.json") << "{}";
    std::vector<std::string> report;
    auto store = Annotations::open(dir, &report);
    ASSERT_TRUE(store.ok());
    EXPECT_EQ(store.value()->list(), before);
    ASSERT_EQ(report.size(), 4u);
    std::string all;
    for (const auto& l : report) all += l + "\n";
    EXPECT_NE(all.find("7.json: skipped: not JSON"), std::string::npos) << all;
    EXPECT_NE(all.find("8.json: skipped: the record has id 2, its file 8"), std::string::npos) << all;
    EXPECT_NE(all.find("9.json: skipped: annotation.text: 2001 characters"), std::string::npos) << all;
    EXPECT_NE(all.find("notes.json: skipped"), std::string::npos) << all;
    // A new one takes an id past the damaged files: they stay for their owner to look at.
    auto next = store.value()->add(shape({{"kind", "pin"}, {"points", {{1, 1}}}, {"text", "x"}}), 320, 180, 9, "e");
    ASSERT_TRUE(next.ok());
    EXPECT_EQ((*next)["id"], 10);
    EXPECT_TRUE(std::filesystem::exists(dir / "7.json"));
    std::filesystem::remove_all(dir);
}
