// Session and Journal without a GPU: edits, undo/redo, conflicts, and persistence: the journal
// replays to the exact rig and history, a line cut short by a crash is dropped, a damaged line is
// refused with its line number and the file left as it was.

#include "session/Session.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

using namespace dfb;
using json = nlohmann::json;

namespace {

std::filesystem::path freshDir(const std::string& name) {
    auto d = std::filesystem::temp_directory_path() / ("dfb_session_" + name + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(d);
    return d;
}

std::unique_ptr<Session> open(const std::filesystem::path& dir) {
    static const DeepBuffer shot;
    auto s = Session::open("test", shot, "shot.exr", defaultRig({-1, 0, -1}, {1, 1, 1}), dir);
    EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().toString());
    return s.ok() ? std::move(s.value()) : nullptr;
}

std::string readAll(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

float intensity(const Session& s) { return s.rig().find("key")->intensityCd; }

} // namespace

TEST(Session, EditsUndoRedoAndConflicts) {
    auto s = open({});
    ASSERT_TRUE(s);
    const uint64_t v0 = s->rigVersion();
    const Author alice{1, "alice"}, bob{2, "bob"};
    ASSERT_TRUE(s->edit({{"key.intensity", 10}}, alice).ok());
    ASSERT_TRUE(s->edit({{"key.intensity", 20}}, bob).ok());
    EXPECT_EQ(s->rigVersion(), v0 + 2);
    // Alice edits from v0 + 1: Bob's change at v0 + 2 is reported as overwritten.
    auto r = s->edit({{"key.intensity", 30}}, alice, v0 + 1);
    ASSERT_TRUE(r.ok());
    ASSERT_EQ(r->overwrote.size(), 1u);
    EXPECT_EQ(r->overwrote[0]["by"], 2);
    EXPECT_EQ(s->edit({{"key.intensity", 40}}, alice, std::nullopt, v0).error().code, ErrorCode::Conflict);
    EXPECT_EQ(s->edit({{"key.intensity", -1}}, alice).error().code, ErrorCode::InvalidValue);
    EXPECT_EQ(s->rigVersion(), v0 + 3);
    ASSERT_TRUE(s->setTime(2.0, alice).ok()); // not an undo step
    ASSERT_TRUE(s->undo(bob).ok());
    EXPECT_FLOAT_EQ(intensity(*s), 20.f);
    EXPECT_DOUBLE_EQ(s->rig().time, 2.0); // undo keeps the clock
    ASSERT_TRUE(s->undo(bob).ok());
    EXPECT_FLOAT_EQ(intensity(*s), 10.f);
    ASSERT_TRUE(s->redo(alice).ok());
    EXPECT_FLOAT_EQ(intensity(*s), 20.f);
    ASSERT_TRUE(s->edit({{"key.intensity", 50}}, alice).ok());
    EXPECT_EQ(s->redo(alice).error().code, ErrorCode::MissingData); // a new edit clears redo
    EXPECT_EQ(s->history(0).size(), 8u);
}

// A drag is many edits; with `merge` its steps after the first are one undo step, which an edit
// by someone else (or an undo) closes. The journal keeps the flag, so a replay has the same history.
TEST(Session, MergedEditsAreOneUndoStep) {
    const auto dir = freshDir("merge");
    const Author alice{1, "alice"}, bob{2, "bob"};
    {
        auto s = open(dir);
        ASSERT_TRUE(s);
        const size_t depth0 = s->undoDepth();
        ASSERT_TRUE(s->edit({{"key.intensity", 10}}, alice).ok());
        ASSERT_TRUE(s->edit({{"key.intensity", 11}}, alice, std::nullopt, std::nullopt, true).ok());
        ASSERT_TRUE(s->edit({{"key.intensity", 12}}, alice, std::nullopt, std::nullopt, true).ok());
        EXPECT_EQ(s->undoDepth(), depth0 + 1);
        // Bob's edit closes alice's step: her next merged edit starts a new one.
        ASSERT_TRUE(s->edit({{"fill.intensity", 3}}, bob, std::nullopt, std::nullopt, true).ok());
        EXPECT_EQ(s->undoDepth(), depth0 + 2);
        ASSERT_TRUE(s->edit({{"key.intensity", 13}}, alice, std::nullopt, std::nullopt, true).ok());
        EXPECT_EQ(s->undoDepth(), depth0 + 3);
    }
    auto s = open(dir);
    ASSERT_TRUE(s);
    EXPECT_FLOAT_EQ(intensity(*s), 13.f);
    ASSERT_TRUE(s->undo(alice).ok());
    EXPECT_FLOAT_EQ(intensity(*s), 12.f);
    ASSERT_TRUE(s->undo(alice).ok()); // bob's
    ASSERT_TRUE(s->undo(alice).ok()); // the whole merged step: 10, 11, 12
    EXPECT_NE(intensity(*s), 10.f);
    EXPECT_NE(intensity(*s), 12.f);
    ASSERT_TRUE(s->redo(alice).ok());
    EXPECT_FLOAT_EQ(intensity(*s), 12.f);
    std::filesystem::remove_all(dir);
}

TEST(Session, JournalReplaysTheExactRigAndHistory) {
    const auto dir = freshDir("replay");
    json rigBefore, historyBefore;
    {
        auto s = open(dir);
        ASSERT_TRUE(s);
        const Author a{1, "a"};
        ASSERT_TRUE(s->edit({{"key.intensity", 10}}, a).ok());
        ASSERT_TRUE(s->edit({{"key.type", "bendy"}, {"key.cp[2]", json::array({3, 0, 1})}}, a).ok());
        ASSERT_TRUE(s->setTime(1.25, a).ok());
        ASSERT_TRUE(s->edit({{"fill.enabled", false}}, a).ok());
        ASSERT_TRUE(s->undo(a).ok());
        Rig replaced = s->rig();
        replaced.exposureStops = 2.f;
        ASSERT_TRUE(s->replace(replaced, a).ok());
        rigBefore = protocol::toJson(s->rig());
        historyBefore = s->history(0);
    }
    auto s = open(dir);
    ASSERT_TRUE(s);
    EXPECT_EQ(protocol::toJson(s->rig()), rigBefore);
    EXPECT_EQ(s->history(0), historyBefore);
    EXPECT_EQ(s->undoDepth(), 3u); // two edits and the replace; the undone one went to redo, then was cleared
    ASSERT_TRUE(s->undo({2, "b"}).ok());
    EXPECT_FLOAT_EQ(s->rig().exposureStops, 0.f);
    EXPECT_EQ(json::parse(readAll(dir / "rig.json")), protocol::toJson(s->rig()));
    std::filesystem::remove_all(dir);
}

TEST(Session, ACutShortLastLineIsDroppedAndADamagedOneRefused) {
    const auto dir = freshDir("torn");
    {
        auto s = open(dir);
        ASSERT_TRUE(s->edit({{"key.intensity", 10}}, {}).ok());
        ASSERT_TRUE(s->edit({{"key.intensity", 20}}, {}).ok());
    }
    const auto journal = dir / "journal.jsonl";
    const std::string good = readAll(journal);
    // A crash in the middle of writing a third line: never acknowledged, dropped on restart.
    std::ofstream(journal, std::ios::app) << R"({"op":"edit","v":4,"changes":[{"path":"key.inten)";
    {
        auto s = open(dir);
        ASSERT_TRUE(s);
        EXPECT_FLOAT_EQ(intensity(*s), 20.f);
        EXPECT_EQ(readAll(journal), good);
        ASSERT_TRUE(s->edit({{"key.intensity", 30}}, {}).ok()); // appends after the cut
    }
    EXPECT_FLOAT_EQ(intensity(*open(dir)), 30.f);
    // A damaged line in the middle: refused, naming the line; the file is not touched.
    std::string text = readAll(journal);
    text.replace(text.find("\"op\":\"edit\""), 4, "\"xx\"");
    std::ofstream(journal, std::ios::trunc | std::ios::binary) << text;
    static const DeepBuffer shot;
    auto bad = Session::open("test", shot, "shot.exr", defaultRig({-1, 0, -1}, {1, 1, 1}), dir);
    ASSERT_FALSE(bad.ok());
    EXPECT_EQ(bad.error().code, ErrorCode::InvalidFile);
    EXPECT_NE(bad.error().message.find("journal.jsonl:2"), std::string::npos) << bad.error().message;
    EXPECT_EQ(readAll(journal), text);
    std::filesystem::remove_all(dir);
}
