// Snapshots and saved rigs (issue 20 point 3; docs/protocol.md "Snapshots and saved rigs") on a
// real dfb-server over loopback, with --state:
//  - an editor snapshots the frame of the moment: the entry names the rig version, the author
//    (X-Dfb-Name) and the frame's size; its JPEG is the shot's size, the thumbnail at most 240
//    wide; every WebSocket client hears a `library` message; a viewer may read but not take,
//    delete or load; bad names, names in use and unknown entries are refused with their reason;
//  - a saved rig loads back as one undoable edit (undo returns to the rig before the load);
//  - after a restart on the same --state the snapshots (images byte for byte) and rigs are there;
//    a damaged record is skipped and named in the log, the others kept.

#include "support/NetClient.h"
#include "support/Process.h"
#include "support/TestServer.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <unistd.h>

using json = nlohmann::json;
using dfb::test::http;

namespace {

const std::string SHOT = DFB_TEST_DATA "/tabletop_320.exr";

// Width and height from a baseline JPEG's SOF0 segment (0 when there is none).
std::pair<int, int> jpegSize(const std::string& b) {
    for (size_t i = 2; i + 8 < b.size();) {
        if (uint8_t(b[i]) != 0xFF) break;
        const uint8_t marker = uint8_t(b[i + 1]);
        const size_t len = (size_t(uint8_t(b[i + 2])) << 8) | uint8_t(b[i + 3]);
        if (marker == 0xC0) return {(int(uint8_t(b[i + 7])) << 8) | uint8_t(b[i + 8]), (int(uint8_t(b[i + 5])) << 8) | uint8_t(b[i + 6])};
        i += 2 + len;
    }
    return {0, 0};
}

} // namespace

TEST(ServerLibrary, SnapshotsAndSavedRigsAreSharedUndoableAndKeptAcrossRestarts) {
    ASSERT_TRUE(std::filesystem::exists(SHOT)) << "run the bake_tabletop_fixture test first";
    const auto state = std::filesystem::temp_directory_path() / ("dfb_library_" + std::to_string(::getpid()));
    std::filesystem::remove_all(state);
    std::string firstImage, firstThumb;
    std::string id;
    {
        dfb::test::Server server({SHOT, "--state", state.string()});
        ASSERT_TRUE(server.up()) << server.process->output();
        id = server.onlySession();
        const auto& t = server.tokens[id];
        const std::string base = "/v1/sessions/" + id;
        dfb::test::WsClient watcher(server.port, id, t.viewer);
        watcher.nextText(); // welcome

        auto r = http(server.port, "POST", base + "/snapshots", t.editor, R"({"name": "first"})", {{"X-Dfb-Name", "alice"}});
        ASSERT_EQ(r.status, 200) << r.body;
        json snap = r.json();
        EXPECT_EQ(snap["name"], "first");
        EXPECT_EQ(snap["by"], "alice");
        EXPECT_EQ(snap["rigVersion"], 1);
        EXPECT_EQ(snap["width"], 320);
        EXPECT_EQ(snap["height"], 180);
        const json told = watcher.nextText({"presence", "frame", "change"});
        EXPECT_EQ(told["type"], "library");
        ASSERT_EQ(told["snapshots"].size(), 1u);
        EXPECT_EQ(told["snapshots"][0]["name"], "first");

        auto img = http(server.port, "GET", base + "/snapshots/first.jpg", t.viewer);
        ASSERT_EQ(img.status, 200) << img.body;
        EXPECT_EQ(img.headers["Content-Type"], "image/jpeg");
        EXPECT_EQ(jpegSize(img.body), std::make_pair(320, 180));
        auto thumb = http(server.port, "GET", base + "/snapshots/first.thumb.jpg", t.viewer);
        ASSERT_EQ(thumb.status, 200);
        const auto [tw, th] = jpegSize(thumb.body);
        EXPECT_GT(tw, 0);
        EXPECT_LE(tw, 240);
        EXPECT_NEAR(double(th) / tw, 180.0 / 320.0, 0.02);
        firstImage = img.body, firstThumb = thumb.body;

        // Refusals, each with its reason; nothing changes.
        r = http(server.port, "POST", base + "/snapshots", t.editor, R"({"name": "first"})");
        EXPECT_EQ(r.json()["code"], "conflict") << r.body;
        EXPECT_NE(r.body.find("exists"), std::string::npos);
        r = http(server.port, "POST", base + "/snapshots", t.editor, R"({"name": "no spaces"})");
        EXPECT_EQ(r.status, 400) << r.body;
        EXPECT_NE(r.body.find("1-64 characters"), std::string::npos) << r.body;
        r = http(server.port, "POST", base + "/snapshots", t.editor, R"({"title": "x"})");
        EXPECT_EQ(r.status, 400) << r.body;
        r = http(server.port, "POST", base + "/snapshots", t.viewer, R"({"name": "mine"})");
        EXPECT_EQ(r.status, 403) << r.body;
        r = http(server.port, "DELETE", base + "/snapshots/first", t.viewer);
        EXPECT_EQ(r.status, 403) << r.body;
        r = http(server.port, "GET", base + "/snapshots/nosuch.jpg", t.viewer);
        EXPECT_EQ(r.status, 404) << r.body;
        EXPECT_NE(r.body.find("no snapshot named 'nosuch'"), std::string::npos) << r.body;

        // A saved rig, an edit, the load (one edit), its undo.
        r = http(server.port, "POST", base + "/rigs", t.editor, R"({"name": "look-a"})");
        ASSERT_EQ(r.status, 200) << r.body;
        const json rigA = server.rig(id);
        r = http(server.port, "POST", base + "/edits", t.editor, R"({"changes": [{"path": "key.intensity", "value": 3}]})");
        ASSERT_EQ(r.status, 200) << r.body;
        const json edited = server.rig(id);
        ASSERT_NE(edited["lights"], rigA["lights"]);
        r = http(server.port, "POST", base + "/rigs/look-a/load", t.viewer);
        EXPECT_EQ(r.status, 403) << r.body;
        r = http(server.port, "POST", base + "/rigs/look-a/load", t.editor);
        ASSERT_EQ(r.status, 200) << r.body;
        EXPECT_EQ(r.json()["loaded"], "rig look-a");
        json now = server.rig(id);
        EXPECT_EQ(now["lights"], rigA["lights"]);
        EXPECT_EQ(now["version"], edited["version"].get<uint64_t>() + 1);
        r = http(server.port, "POST", base + "/undo", t.editor);
        ASSERT_EQ(r.status, 200) << r.body;
        const json undone = server.rig(id);
        EXPECT_EQ(undone["lights"], edited["lights"]) << "one undo takes the load back";
        // The snapshot's rig loads too; GET names the rig it shows.
        r = http(server.port, "GET", base + "/snapshots/first", t.viewer);
        ASSERT_EQ(r.status, 200);
        EXPECT_EQ(r.json()["rig"]["lights"], rigA["lights"]);
        r = http(server.port, "POST", base + "/rigs/nosuch/load", t.editor);
        EXPECT_EQ(r.status, 404) << r.body;

        // "Go to this version" over the WebSocket: the editor's restore is one edit; a viewer's is refused.
        {
            dfb::test::WsClient editor(server.port, id, t.editor);
            editor.nextText(); // welcome
            editor.send(R"({"type": "restore", "seq": 5, "version": )" + std::to_string(rigA["version"].get<uint64_t>()) + "}");
            const json ack = editor.nextText({"presence", "change", "library"});
            EXPECT_EQ(ack["type"], "ack") << ack.dump();
            EXPECT_EQ(server.rig(id)["lights"], rigA["lights"]);
            watcher.send(std::string(R"({"type": "restore", "seq": 6, "version": 1})"));
            const json refused = watcher.nextText({"presence", "change", "library"});
            EXPECT_EQ(refused["code"], "forbidden") << refused.dump();
            editor.send(std::string(R"({"type": "restore", "seq": 7, "version": 999999})"));
            const json missing = editor.nextText({"presence", "change", "library"});
            EXPECT_EQ(missing["code"], "missing_data") << missing.dump();
            EXPECT_NE(missing.value("message", "").find("not in the session's history"), std::string::npos) << missing.dump();
            ASSERT_EQ(http(server.port, "POST", base + "/undo", t.editor).status, 200);
        }
        // A second snapshot and rig, then one of each deleted.
        const json atSecond = server.rig(id);
        ASSERT_EQ(http(server.port, "POST", base + "/snapshots", t.editor, R"({"name": "second"})").status, 200);
        ASSERT_EQ(http(server.port, "POST", base + "/rigs", t.editor, R"({"name": "gone"})").status, 200);
        ASSERT_EQ(http(server.port, "DELETE", base + "/rigs/gone", t.editor).status, 200);
        auto list = http(server.port, "GET", base + "/library", t.viewer).json();
        ASSERT_EQ(list["snapshots"].size(), 2u) << list.dump();
        ASSERT_EQ(list["rigs"].size(), 1u) << list.dump();
        EXPECT_EQ(list["snapshots"][1]["rigVersion"], atSecond["version"]) << "a snapshot names the version it shows";
    }
    // A damaged record beside the good ones.
    const auto lib = state / id / "library";
    ASSERT_TRUE(std::filesystem::exists(lib / "snapshots" / "first.json"));
    std::ofstream(lib / "rigs" / "broken.json") << "{\"name\": \"broken\", \"rig\": ";
    {
        dfb::test::Server server({SHOT, "--state", state.string()});
        ASSERT_TRUE(server.up()) << server.process->output();
        EXPECT_NE(server.process->output().find("broken.json: skipped: not JSON"), std::string::npos) << server.process->output();
        const auto& t = server.tokens[id];
        const std::string base = "/v1/sessions/" + id;
        auto list = http(server.port, "GET", base + "/library", t.viewer).json();
        ASSERT_EQ(list["snapshots"].size(), 2u) << list.dump();
        ASSERT_EQ(list["rigs"].size(), 1u) << list.dump();
        EXPECT_EQ(list["rigs"][0]["name"], "look-a");
        EXPECT_EQ(http(server.port, "GET", base + "/snapshots/first.jpg", t.viewer).body, firstImage);
        EXPECT_EQ(http(server.port, "GET", base + "/snapshots/first.thumb.jpg", t.viewer).body, firstThumb);
        // Deleting removes the files.
        ASSERT_EQ(http(server.port, "DELETE", base + "/snapshots/first", t.editor).status, 200);
        EXPECT_FALSE(std::filesystem::exists(lib / "snapshots" / "first.json"));
        EXPECT_FALSE(std::filesystem::exists(lib / "snapshots" / "first.jpg"));
        EXPECT_TRUE(std::filesystem::exists(lib / "rigs" / "broken.json")) << "a damaged file is left for its owner";
    }
    std::filesystem::remove_all(state);
}
