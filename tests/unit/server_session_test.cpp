// Session and Journal without a GPU: edits, undo/redo, conflicts, and persistence: the journal
// replays to the exact rig and history; a record cut short by a crash or a full disk is moved
// aside and reported; a damaged record before the end is refused with its line number and the file
// left as it was; a failed write refuses the edit and leaves no fragment; a lost journal is never
// a silent restart at version 1; snapshots bound the journal and restore the same state. Every
// case checks that no acknowledged edit is lost.

#include "session/Session.h"

#include <dfb/protocol/Codec.h>

#include <OpenImageIO/imageio.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <fstream>
#include <regex>
#include <sstream>

#include <sys/mount.h>
#include <unistd.h>

using namespace dfb;
using json = nlohmann::json;

namespace {

std::filesystem::path freshDir(const std::string& name) {
    auto d = std::filesystem::temp_directory_path() / ("dfb_session_" + name + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(d);
    return d;
}

Result<std::unique_ptr<Session>> tryOpen(const std::filesystem::path& dir,
                                         size_t snapshotEvery = Session::SNAPSHOT_EVERY) {
    static const DeepBuffer shot;
    return Session::open("test", shot, "shot.exr", defaultRig({-1, 0, -1}, {1, 1, 1}), dir,
                         snapshotEvery);
}

std::unique_ptr<Session> open(const std::filesystem::path& dir,
                              size_t snapshotEvery = Session::SNAPSHOT_EVERY) {
    auto s = tryOpen(dir, snapshotEvery);
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

void writeFile(const std::filesystem::path& p, const std::string& text) {
    std::ofstream(p, std::ios::trunc | std::ios::binary) << text;
}

std::vector<std::string> lines(const std::string& text) {
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string l; std::getline(in, l);)
        out.push_back(l);
    return out;
}

// The files journal.corrupt-* in `dir`.
std::vector<std::filesystem::path> asideFiles(const std::filesystem::path& dir) {
    std::vector<std::filesystem::path> out;
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
        if (e.path().filename().string().rfind("journal.corrupt-", 0) == 0)
            out.push_back(e.path());
    }
    return out;
}

// Everything a restart must restore, for comparing two sessions.
json state(const Session& s) {
    return {{"rig", protocol::toJson(s.rig())},
            {"undo", s.undoDepth()},
            {"redo", s.redoDepth()},
            {"history", s.history(0)}};
}

// Turns off the injected write failures however a test ends.
struct WriteFailures {
    explicit WriteFailures(size_t afterBytes) {
        Journal::failWritesAfterBytesForTesting(afterBytes);
    }
    ~WriteFailures() { Journal::failWritesAfterBytesForTesting(Journal::NO_LIMIT); }
};

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

TEST(Journal, Crc32cIsCastagnoli) {
    EXPECT_EQ(crc32c("123456789"), 0xE3069283u); // the check value of CRC-32C (iSCSI)
    EXPECT_EQ(crc32c(""), 0u);
}

// Each line: "<length> <crc32c> <json>", the length and checksum those of the JSON text.
TEST(Session, RecordsCarryTheirLengthAndChecksum) {
    const auto dir = freshDir("format");
    {
        auto s = open(dir);
        ASSERT_TRUE(s->edit({{"key.intensity", 10}}, {}).ok());
        ASSERT_TRUE(s->undo({}).ok());
    }
    const auto ls = lines(readAll(dir / "journal.jsonl"));
    ASSERT_EQ(ls.size(), 3u);
    const std::regex record(R"(^([0-9]+) ([0-9a-f]{8}) (\{.*\})$)");
    for (const std::string& l : ls) {
        std::smatch m;
        ASSERT_TRUE(std::regex_match(l, m, record)) << l;
        EXPECT_EQ(std::stoul(m[1]), m[3].length());
        EXPECT_EQ(std::stoul(m[2], nullptr, 16), crc32c(m[3].str()));
        EXPECT_TRUE(json::parse(m[3].str()).contains("op"));
    }
    std::filesystem::remove_all(dir);
}

// Journals written before records had a checksum (plain JSON lines) still load; new records are
// appended in the new form after them.
TEST(Session, AJournalOfPlainJsonLinesStillLoads) {
    const auto dir = freshDir("legacy");
    std::filesystem::create_directories(dir);
    const json base = protocol::toJson(defaultRig({-1, 0, -1}, {1, 1, 1}));
    writeFile(
        dir / "journal.jsonl",
        protocol::dump(json{{"op", "base"}, {"rig", base}}) + "\n" +
            R"({"op":"edit","v":2,"by":1,"byName":"a","changes":[{"path":"key.intensity","value":10}]})" +
            "\n" +
            R"({"op":"edit","v":3,"by":1,"byName":"a","changes":[{"path":"key.intensity","value":20}]})" +
            "\n");
    {
        auto s = open(dir);
        ASSERT_TRUE(s);
        EXPECT_TRUE(s->recoveryReport().empty());
        EXPECT_EQ(s->rigVersion(), 3u);
        EXPECT_FLOAT_EQ(intensity(*s), 20.f);
        ASSERT_TRUE(s->edit({{"key.intensity", 30}}, {}).ok());
    }
    const auto ls = lines(readAll(dir / "journal.jsonl"));
    ASSERT_EQ(ls.size(), 4u);
    EXPECT_EQ(ls[2][0], '{');
    EXPECT_NE(ls[3][0], '{'); // the new record has its length and checksum
    auto s = open(dir);
    ASSERT_TRUE(s);
    EXPECT_EQ(s->rigVersion(), 4u);
    EXPECT_FLOAT_EQ(intensity(*s), 30.f);
    ASSERT_TRUE(s->undo({}).ok());
    EXPECT_FLOAT_EQ(intensity(*s), 20.f);
    std::filesystem::remove_all(dir);
}

// A write that fails part way (a full disk) is cut off again: the edit is refused, nothing changes
// in memory, the next edits succeed, and a restart replays exactly the acknowledged ones.
TEST(Session, AFailedWriteIsRolledBackAndTheEditRefused) {
    const auto dir = freshDir("failwrite");
    const auto journal = dir / "journal.jsonl";
    {
        auto s = open(dir);
        ASSERT_TRUE(s->edit({{"key.intensity", 10}}, {}).ok());
        const std::string before = readAll(journal);
        const uint64_t v = s->rigVersion();
        for (size_t budget : {size_t(0), size_t(1), size_t(25)}) {
            WriteFailures failing(budget); // the record is written in part, then ENOSPC
            auto r = s->edit({{"key.intensity", 99}}, {});
            ASSERT_FALSE(r.ok());
            EXPECT_EQ(r.error().code, ErrorCode::IoError);
            EXPECT_STREQ(toString(r.error().code), "io_error");
            EXPECT_EQ(s->rigVersion(), v);
            EXPECT_FLOAT_EQ(intensity(*s), 10.f);
            EXPECT_EQ(readAll(journal), before);                     // no fragment left
            EXPECT_EQ(s->undo({}).error().code, ErrorCode::IoError); // undo is journaled too
            EXPECT_EQ(s->rigVersion(), v);
        }
        ASSERT_TRUE(s->edit({{"key.intensity", 20}}, {}).ok());
        ASSERT_TRUE(s->edit({{"key.intensity", 30}}, {}).ok());
        EXPECT_EQ(s->rigVersion(), v + 2);
    }
    auto s = open(dir);
    ASSERT_TRUE(s);
    EXPECT_TRUE(s->recoveryReport().empty());
    EXPECT_FLOAT_EQ(intensity(*s), 30.f);
    EXPECT_EQ(s->rigVersion(), 4u);
    EXPECT_EQ(s->history(0).size(), 3u); // 10, 20, 30: nothing of the refused ones
    EXPECT_TRUE(asideFiles(dir).empty());
    std::filesystem::remove_all(dir);
}

// The same with a real full disk: a 64 KiB tmpfs (needs root and mount; skipped otherwise).
TEST(Session, ARealFullDiskRefusesTheEditAndLosesNothing) {
    const auto dir = freshDir("enospc");
    std::filesystem::create_directories(dir);
    if (::geteuid() != 0 || ::mount("tmpfs", dir.c_str(), "tmpfs", 0, "size=64k") != 0) {
        std::filesystem::remove_all(dir);
        GTEST_SKIP() << "cannot mount a tmpfs (needs root): " << std::strerror(errno);
    }
    const auto sdir = dir / "s";
    float acked = 0.f;
    uint64_t ackedVersion = 0;
    {
        auto s = open(sdir);
        ASSERT_TRUE(s);
        writeFile(dir / "ballast", std::string(8192, 'x')); // freed later to make room again
        bool refused = false;
        for (int i = 1; i < 20000 && !refused; ++i) {
            const uint64_t v = s->rigVersion();
            auto r = s->edit({{"key.intensity", float(i)}}, {});
            if (r.ok()) {
                acked = float(i);
                ackedVersion = s->rigVersion();
                continue;
            }
            refused = true;
            EXPECT_EQ(r.error().code, ErrorCode::IoError) << r.error().toString();
            EXPECT_EQ(s->rigVersion(), v);
            EXPECT_FLOAT_EQ(intensity(*s), acked);
        }
        ASSERT_TRUE(refused) << "the disk never filled";
        std::filesystem::remove(dir / "ballast");
        auto r = s->edit({{"key.intensity", 0.5f}}, {});
        ASSERT_TRUE(r.ok()) << r.error().toString();
        acked = 0.5f;
        ackedVersion = s->rigVersion();
    }
    {
        auto s = open(sdir);
        ASSERT_TRUE(s);
        EXPECT_TRUE(s->recoveryReport().empty()) << s->recoveryReport();
        EXPECT_FLOAT_EQ(intensity(*s), acked);
        EXPECT_EQ(s->rigVersion(), ackedVersion);
    }
    ::umount2(dir.c_str(), MNT_DETACH);
    std::filesystem::remove_all(dir);
}

TEST(Session, ACutShortLastLineIsMovedAsideAndADamagedOneRefused) {
    const auto dir = freshDir("torn");
    {
        auto s = open(dir);
        ASSERT_TRUE(s->edit({{"key.intensity", 10}}, {}).ok());
        ASSERT_TRUE(s->edit({{"key.intensity", 20}}, {}).ok());
    }
    const auto journal = dir / "journal.jsonl";
    const std::string good = readAll(journal);
    // A crash in the middle of writing a fourth record: never acknowledged; moved aside on restart.
    const std::string fragment = R"(97 0badc0de {"op":"edit","v":4,"changes":[{"path":"key.inten)";
    std::ofstream(journal, std::ios::app) << fragment;
    {
        auto s = open(dir);
        ASSERT_TRUE(s);
        EXPECT_FLOAT_EQ(intensity(*s), 20.f);
        EXPECT_EQ(readAll(journal), good);
        const auto aside = asideFiles(dir);
        ASSERT_EQ(aside.size(), 1u);
        EXPECT_EQ(readAll(aside[0]), fragment);
        const std::string report = s->recoveryReport();
        EXPECT_NE(report.find("journal.jsonl:4"), std::string::npos) << report;
        EXPECT_NE(report.find("torn"), std::string::npos) << report;
        EXPECT_NE(report.find(aside[0].string()), std::string::npos) << report;
        ASSERT_TRUE(s->edit({{"key.intensity", 30}}, {}).ok()); // appends after the cut
    }
    {
        auto s = open(dir);
        EXPECT_FLOAT_EQ(intensity(*s), 30.f);
        EXPECT_TRUE(s->recoveryReport().empty());
    }
    // A damaged line in the middle: refused, naming the line; the file is not touched.
    std::string text = readAll(journal);
    text.replace(text.find("\"op\":\"edit\""), 4, "\"xx\"");
    writeFile(journal, text);
    auto bad = tryOpen(dir);
    ASSERT_FALSE(bad.ok());
    EXPECT_EQ(bad.error().code, ErrorCode::InvalidFile);
    EXPECT_NE(bad.error().message.find("journal.jsonl:2: checksum mismatch"), std::string::npos)
        << bad.error().message;
    EXPECT_EQ(readAll(journal), text);
    EXPECT_EQ(asideFiles(dir).size(), 1u);
    std::filesystem::remove_all(dir);
}

// A changed digit is caught by the checksum: in the last record it is moved aside (and, as
// rig.json shows that record was acknowledged, the report says so); before it, refused.
TEST(Session, AChangedDigitIsCaughtByTheChecksum) {
    const auto dir = freshDir("digit");
    const auto journal = dir / "journal.jsonl";
    {
        auto s = open(dir);
        ASSERT_TRUE(s->edit({{"key.intensity", 10}}, {}).ok());
        ASSERT_TRUE(s->edit({{"key.intensity", 20}}, {}).ok());
        ASSERT_TRUE(s->edit({{"key.intensity", 30}}, {}).ok());
    }
    const std::string good = readAll(journal);
    std::string text = good;
    text.replace(text.find("\"value\":10"), 10, "\"value\":17"); // line 2
    writeFile(journal, text);
    auto bad = tryOpen(dir);
    ASSERT_FALSE(bad.ok());
    EXPECT_EQ(bad.error().code, ErrorCode::InvalidFile);
    EXPECT_NE(bad.error().message.find((dir / "journal.jsonl").string() + ":2: checksum mismatch"),
              std::string::npos)
        << bad.error().message;
    EXPECT_EQ(readAll(journal), text);
    EXPECT_TRUE(asideFiles(dir).empty());

    text = good;
    text.replace(text.find("\"value\":30"), 10, "\"value\":37"); // the last line, 4
    writeFile(journal, text);
    auto s = open(dir);
    ASSERT_TRUE(s);
    const std::string report = s->recoveryReport();
    EXPECT_NE(report.find("journal.jsonl:4: checksum mismatch"), std::string::npos) << report;
    EXPECT_NE(report.find("acknowledged"), std::string::npos) << report;
    EXPECT_FLOAT_EQ(intensity(*s), 20.f); // never the damaged 37
    ASSERT_EQ(asideFiles(dir).size(), 1u);
    EXPECT_EQ(readAll(asideFiles(dir)[0]), lines(text)[3] + "\n");
    EXPECT_EQ(lines(readAll(journal)).size(), 3u);
    std::filesystem::remove_all(dir);
}

// An empty or deleted journal beside a rig.json at version > 1, or beside a snapshot, is refused:
// never a fresh start at version 1 that would drop every change.
TEST(Session, ALostJournalIsRefusedNotRestartedAtVersionOne) {
    const auto dir = freshDir("lost");
    const auto journal = dir / "journal.jsonl";
    {
        auto s = open(dir, 3);
        for (int i = 1; i <= 5; ++i)
            ASSERT_TRUE(s->edit({{"key.intensity", float(i)}}, {}).ok());
    }
    const std::string good = readAll(journal);
    ASSERT_TRUE(std::filesystem::exists(dir / "snapshot.jsonl"));
    // 3 changes, then a snapshot at version 4, then 2 more changes.
    for (bool remove : {false, true}) {
        if (remove)
            std::filesystem::remove(journal);
        else
            writeFile(journal, "");
        auto bad = tryOpen(dir, 3);
        ASSERT_FALSE(bad.ok());
        EXPECT_EQ(bad.error().code, ErrorCode::InvalidFile);
        EXPECT_NE(bad.error().message.find("snapshot.jsonl"), std::string::npos)
            << bad.error().message;
        EXPECT_NE(bad.error().message.find("version 4"), std::string::npos) << bad.error().message;
    }
    std::filesystem::remove(dir / "snapshot.jsonl");
    auto bad = tryOpen(dir);
    ASSERT_FALSE(bad.ok());
    EXPECT_EQ(bad.error().code, ErrorCode::InvalidFile);
    EXPECT_NE(bad.error().message.find("rig.json is at version 6"), std::string::npos)
        << bad.error().message;
    EXPECT_FALSE(std::filesystem::exists(journal)); // left missing, as it was
    // A journal that continues a snapshot which has gone is refused too.
    writeFile(journal, good);
    bad = tryOpen(dir, 3);
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().message.find("snapshot.jsonl is missing"), std::string::npos)
        << bad.error().message;
    EXPECT_EQ(readAll(journal), good);
    std::filesystem::remove_all(dir);
}

// Drives a session through every kind of change (merged drags across snapshots included).
void manyChanges(Session& s, int count) {
    const Author alice{1, "alice"}, bob{2, "bob"};
    for (int i = 0; i < count; ++i) {
        switch (i % 9) {
        case 0:
        case 1:
        case 2:
            ASSERT_TRUE(
                s.edit({{"key.intensity", float(i)}}, alice, std::nullopt, std::nullopt, true)
                    .ok());
            break;
        case 3:
            ASSERT_TRUE(s.edit({{"fill.intensity", float(i)}}, bob).ok());
            break;
        case 4:
            ASSERT_TRUE(s.setTime(i * 0.5, bob).ok());
            break;
        case 5:
            ASSERT_TRUE(s.undo(bob).ok());
            break;
        case 6: {
            Rig r = s.rig();
            r.exposureStops = float(i % 7) * 0.25f;
            ASSERT_TRUE(s.replace(r, alice).ok());
            break;
        }
        case 7:
            ASSERT_TRUE(s.undo(alice).ok());
            break;
        case 8:
            ASSERT_TRUE(s.redo(alice).ok());
            break;
        }
    }
}

// With a snapshot every 7 records the journal stays small however many changes; a restart
// restores the rig, version, undo/redo stacks and history, and undo after it behaves the same.
TEST(Session, SnapshotsKeepTheJournalBoundedAndRestoreTheSameState) {
    const auto dir = freshDir("snapshot"), copy = freshDir("snapshot_copy");
    const auto journal = dir / "journal.jsonl";
    json before, afterUndo;
    {
        auto s = open(dir, 7);
        size_t largest = 0;
        for (int round = 0; round < 40; ++round) {
            manyChanges(*s, 10);
            largest = std::max(largest, size_t(std::filesystem::file_size(journal)));
            EXPECT_LE(lines(readAll(journal)).size(), 8u);
        }
        EXPECT_LT(largest, 8u * 1024u); // 400 changes: ~100 KB without compaction
        EXPECT_EQ(s->rigVersion(), 401u);
        before = state(*s);
        std::filesystem::copy(dir, copy);
        ASSERT_TRUE(s->undo({}).ok());
        ASSERT_TRUE(s->undo({}).ok());
        afterUndo = state(*s);
    }
    auto s = open(copy, 7);
    ASSERT_TRUE(s);
    EXPECT_TRUE(s->recoveryReport().empty());
    EXPECT_EQ(state(*s), before);
    ASSERT_TRUE(s->undo({}).ok());
    ASSERT_TRUE(s->undo({}).ok());
    EXPECT_EQ(state(*s), afterUndo);
    // A merged edit right after the restart does not merge into the step from before it.
    const size_t depth = s->undoDepth();
    ASSERT_TRUE(
        s->edit({{"key.intensity", 1}}, {1, "alice"}, std::nullopt, std::nullopt, true).ok());
    EXPECT_EQ(s->undoDepth(), depth + 1);
    std::filesystem::remove_all(dir);
    std::filesystem::remove_all(copy);
}

// A drag whose merged edits straddle a snapshot is still one undo step after a restart: the
// snapshot keeps whose step may take merges, so the replayed merged edits join it as they did live.
TEST(Session, AMergedDragAcrossASnapshotIsStillOneUndoStep) {
    const auto dir = freshDir("dragsnap"), copy = freshDir("dragsnap_copy");
    const Author alice{1, "alice"};
    json before;
    {
        auto s = open(dir, 2);
        for (int i = 1; i <= 5; ++i)
            ASSERT_TRUE(
                s->edit({{"key.intensity", float(i)}}, alice, std::nullopt, std::nullopt, true)
                    .ok());
        EXPECT_EQ(s->undoDepth(), 1u);
        ASSERT_EQ(lines(readAll(dir / "journal.jsonl")).size(),
                  2u); // the snapshot record and the fifth edit
        before = state(*s);
        std::filesystem::copy(dir, copy);
    }
    auto s = open(copy, 2);
    ASSERT_TRUE(s);
    EXPECT_EQ(state(*s), before);
    ASSERT_TRUE(s->undo(alice).ok());
    EXPECT_EQ(s->undoDepth(), 0u);
    EXPECT_NE(intensity(*s), 1.f); // the whole drag, not only its last edit
    std::filesystem::remove_all(dir);
    std::filesystem::remove_all(copy);
}

// A crash after the snapshot was written but before the journal was compacted: the old journal
// still holds the records the snapshot covers; they are skipped, and the state is the same.
TEST(Session, ACrashBetweenSnapshotAndCompactionOpensToTheSameState) {
    const auto plain = freshDir("crash_plain"), snap = freshDir("crash_snap");
    json expected;
    {
        auto a = open(plain); // no snapshot yet: the journal as it was before the compaction
        auto b = open(snap, 10);
        manyChanges(*a, 10);
        manyChanges(*b, 10); // the tenth change wrote the snapshot and compacted the journal
        ASSERT_EQ(lines(readAll(snap / "journal.jsonl")).size(), 1u);
        expected = state(*a);
        EXPECT_EQ(state(*b), expected);
    }
    std::filesystem::copy_file(plain / "journal.jsonl", snap / "journal.jsonl",
                               std::filesystem::copy_options::overwrite_existing);
    {
        auto s = open(snap, 10);
        ASSERT_TRUE(s);
        EXPECT_EQ(state(*s), expected);
        // The next change snapshots again and compacts the journal that the crash left long.
        ASSERT_TRUE(s->edit({{"key.intensity", 5}}, {}).ok());
        EXPECT_EQ(lines(readAll(snap / "journal.jsonl")).size(), 1u);
        expected = state(*s);
    }
    auto s = open(snap, 10);
    ASSERT_TRUE(s);
    EXPECT_EQ(state(*s), expected);
    EXPECT_FLOAT_EQ(intensity(*s), 5.f);

    // A snapshot that the journal does not reach (an older journal put back) is refused.
    std::filesystem::copy_file(plain / "journal.jsonl", snap / "journal.jsonl",
                               std::filesystem::copy_options::overwrite_existing);
    const std::string old = readAll(snap / "journal.jsonl");
    writeFile(snap / "journal.jsonl",
              old.substr(0, old.rfind('\n', old.size() - 2) + 1)); // one record short
    auto bad = tryOpen(snap, 10);
    ASSERT_FALSE(bad.ok());
    EXPECT_EQ(bad.error().code, ErrorCode::InvalidFile);
    EXPECT_NE(bad.error().message.find("does not continue the snapshot"), std::string::npos)
        << bad.error().message;
    std::filesystem::remove_all(plain);
    std::filesystem::remove_all(snap);
}

namespace {

// Writes a w x h RGB image of `format` (the environment map refusals below).
void writeImage(const std::filesystem::path& p, int w, int h, OIIO::TypeDesc format) {
    std::vector<float> px(size_t(w) * size_t(h) * 3, 0.5f);
    auto out = OIIO::ImageOutput::create(p.string());
    ASSERT_TRUE(out && out->open(p.string(), OIIO::ImageSpec(w, h, 3, format)) && out->write_image(OIIO::TypeDesc::FLOAT, px.data()) &&
                out->close())
        << p;
}

} // namespace

// An environment light's map is checked when it is named (header only): a PNG, a map over the
// size limit or a missing file is refused naming the light, the row and why; the rig is unchanged.
TEST(Session, EnvironmentMapsAreCheckedWhenNamed) {
    const auto dir = freshDir("envmaps");
    std::filesystem::create_directories(dir);
    auto s = open({});
    ASSERT_TRUE(s);
    s->setAssetDirectory(dir.string());
    writeImage(dir / "sky.exr", 64, 32, OIIO::TypeDesc::HALF);
    writeImage(dir / "ldr.png", 64, 32, OIIO::TypeDesc::UINT16);
    writeImage(dir / "huge.exr", MAX_ENV_MAP_WIDTH + 2, 2, OIIO::TypeDesc::HALF);
    const Author alice{1, "alice"};
    ASSERT_TRUE(s->edit({{"fill.type", "environment"}, {"fill.map", "sky.exr"}}, alice).ok());
    const std::string before = protocol::toJson(s->rig()).dump();
    const struct {
        const char* file;
        const char* words;
    } bad[] = {{"ldr.png", "not float"}, {"huge.exr", "at most 8192x4096"}, {"missing.exr", "missing.exr"}};
    for (const auto& b : bad) {
        auto r = s->edit({{"fill.map", b.file}}, alice);
        ASSERT_FALSE(r.ok()) << b.file;
        EXPECT_EQ(r.error().code, ErrorCode::InvalidValue);
        EXPECT_NE(r.error().message.find("fill.map: '" + std::string(b.file) + "'"), std::string::npos) << r.error().message;
        EXPECT_NE(r.error().message.find(b.words), std::string::npos) << r.error().message;
        EXPECT_EQ(protocol::toJson(s->rig()).dump(), before);
    }
    std::filesystem::remove_all(dir);
}

// "Go to this version" (issue 20 point 4): rigAtVersion rebuilds any version the history holds,
// from the first record's rig before it, the whole rigs of undo/redo/replace and the checkpoints,
// and the changes in between; a restart (journal replay, snapshots) rebuilds the same; versions
// outside the history are refused naming its range; once the log is full the oldest kept version
// still rebuilds. Restoring one is a replace: one undo step.
TEST(Session, AnyVersionInTheHistoryRebuildsAndRestoresAsOneEdit) {
    const auto dir = freshDir("versions");
    std::map<uint64_t, json> seen; // version -> the rig's lights as the session had them
    {
        auto s = open(dir, 50); // snapshots and compaction along the way
        ASSERT_TRUE(s);
        seen[s->rigVersion()] = protocol::toJson(s->rig())["lights"];
        for (int i = 0; i < 150; ++i) {
            auto r = i % 37 == 5 ? s->undo({1, "a"})
                                 : s->edit({{"key.intensity", 1.0 + i}, {"fill.position", json::array({i * 0.01, 1.0, 2.0})}},
                                           {uint64_t(1 + i % 2), i % 2 ? "bob" : "alice"});
            ASSERT_TRUE(r.ok()) << r.error().toString();
            seen[s->rigVersion()] = protocol::toJson(s->rig())["lights"];
        }
        ASSERT_TRUE(s->setTime(1.5, {1, "a"}).ok());
        for (const auto& [v, lights] : seen) {
            auto r = s->rigAtVersion(v);
            ASSERT_TRUE(r.ok()) << v << ": " << r.error().toString();
            EXPECT_EQ(protocol::toJson(r.value())["lights"], lights) << "version " << v;
        }
        auto gone = s->rigAtVersion(s->rigVersion() + 5);
        ASSERT_FALSE(gone.ok());
        EXPECT_EQ(gone.error().code, ErrorCode::MissingData);
        EXPECT_NE(gone.error().message.find("goes back to version 1"), std::string::npos) << gone.error().message;
        // Restoring version 40: one replace, one undo back.
        const json now = protocol::toJson(s->rig())["lights"];
        auto rig40 = s->rigAtVersion(40);
        ASSERT_TRUE(rig40.ok());
        ASSERT_TRUE(s->replace(rig40.value(), {1, "a"}).ok());
        EXPECT_EQ(protocol::toJson(s->rig())["lights"], seen[40]);
        ASSERT_TRUE(s->undo({1, "a"}).ok());
        EXPECT_EQ(protocol::toJson(s->rig())["lights"], now);
        // The history entries do not carry the checkpoints.
        for (const json& e : s->history(0)) {
            EXPECT_FALSE(e.contains("rigAt"));
            EXPECT_FALSE(e.contains("rigBefore"));
        }
    }
    {
        auto s = open(dir, 50);
        ASSERT_TRUE(s);
        for (uint64_t v : {uint64_t(1), uint64_t(2), uint64_t(63), uint64_t(64), uint64_t(65), uint64_t(100), uint64_t(151)}) {
            auto r = s->rigAtVersion(v);
            ASSERT_TRUE(r.ok()) << "after a restart, version " << v << ": " << r.error().toString();
            EXPECT_EQ(protocol::toJson(r.value())["lights"], seen[v]) << "after a restart, version " << v;
        }
    }
    std::filesystem::remove_all(dir);

    // A full log drops its oldest records; the oldest kept version still rebuilds.
    auto m = open({});
    ASSERT_TRUE(m);
    for (size_t i = 0; i < Session::MAX_LOG + 100; ++i) ASSERT_TRUE(m->edit({{"key.intensity", 1.0 + double(i)}}, {1, "a"}).ok());
    const uint64_t oldest = m->history(0)[0]["version"].get<uint64_t>();
    EXPECT_EQ(oldest, m->rigVersion() - Session::MAX_LOG + 1);
    for (uint64_t v : {oldest, oldest + 1, oldest + 63, m->rigVersion() - 1}) {
        auto r = m->rigAtVersion(v);
        ASSERT_TRUE(r.ok()) << v << ": " << r.error().toString();
        EXPECT_FLOAT_EQ(r->find("key")->intensityCd, float(v - 1)) << v; // edit i made version i + 2 with intensity 1 + i
    }
    EXPECT_FALSE(m->rigAtVersion(oldest - 2).ok());
}

// The session description carries the scene's box and each object's, from the covered samples'
// positions: an uncovered sample (A = 0) counts for nothing, an object no covered sample shows
// has null, and a sample of no object (id 0) counts for the scene alone.
TEST(Session, DescriptionCarriesTheSceneAndObjectBounds) {
    DeepBuffer shot;
    shot.allocate(4, 1);
    shot.objectNames = {"table", "bunny", "hidden"};
    const float P[4][3] = {{-1.f, 0.f, 2.f}, {3.f, 0.5f, -1.f}, {0.25f, 1.5f, 0.75f}, {100.f, 100.f, 100.f}};
    const float A[4] = {1.f, 0.5f, 1.f, 0.f};     // the last sample is uncovered
    const uint32_t id[4] = {1, 1, 2, 3};           // "hidden" only on the uncovered one
    for (size_t s = 0; s < 4; ++s) {
        for (int k = 0; k < 3; ++k) shot.P[3 * s + k] = P[s][k];
        shot.A[s] = A[s];
        shot.objectId[s] = id[s];
    }
    auto s = Session::open("boxes", shot, "shot.exr", defaultRig({-1, 0, -1}, {1, 1, 1}), {});
    ASSERT_TRUE(s.ok()) << s.error().toString();
    const json& d = s.value()->description();
    EXPECT_EQ(d["bounds"], json::parse("[-1, 0, -1, 3, 1.5, 2]"));
    EXPECT_EQ(d["objectBounds"], json::parse("[[-1, 0, -1, 3, 0.5, 2], [0.25, 1.5, 0.75, 0.25, 1.5, 0.75], null]"));
    // Floats in their shortest form, as the rig's: 0.1f is written 0.1.
    shot.P[0] = 0.1f;
    auto t = Session::open("boxes", shot, "shot.exr", defaultRig({-1, 0, -1}, {1, 1, 1}), {});
    ASSERT_TRUE(t.ok());
    EXPECT_EQ(t.value()->description()["objectBounds"][0][0].dump(), "0.1");

    // A shot with no samples: no scene box, no objects.
    auto e = tryOpen({});
    ASSERT_TRUE(e.ok());
    EXPECT_TRUE(e.value()->description()["bounds"].is_null());
    EXPECT_EQ(e.value()->description()["objectBounds"], json::array());
}
