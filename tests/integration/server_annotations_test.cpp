// Annotations (issue 20 point 4; docs/protocol.md "Annotations") on a real dfb-server over
// loopback, with --state:
//  - a viewer pins a comment over HTTP (author from X-Dfb-Name, the rig version of the moment)
//    and another over the WebSocket (`annotate`, acknowledged with the annotation); every
//    WebSocket client hears the whole list in an `annotations` message;
//  - a viewer may resolve and reopen but not delete; an editor deletes; a point outside the shot
//    and a malformed body are refused with the field named;
//  - after a restart on the same --state the annotations are there as they were, resolved state
//    included; a damaged file is skipped and named in the log.

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
}

TEST(ServerAnnotations, SharedLiveResolvableAndKeptAcrossRestarts) {
    ASSERT_TRUE(std::filesystem::exists(SHOT)) << "run the bake_tabletop_fixture test first";
    const auto state = std::filesystem::temp_directory_path() / ("dfb_annotations_" + std::to_string(::getpid()));
    std::filesystem::remove_all(state);
    std::string id;
    json kept;
    {
        dfb::test::Server server({SHOT, "--state", state.string()});
        ASSERT_TRUE(server.up()) << server.process->output();
        id = server.onlySession();
        const auto& t = server.tokens[id];
        const std::string base = "/v1/sessions/" + id;
        dfb::test::WsClient watcher(server.port, id, t.editor);
        watcher.nextText(); // welcome
        dfb::test::WsClient reviewer(server.port, id, t.viewer);
        reviewer.send(json{{"type", "hello"}, {"name", "rita"}});
        reviewer.nextText(); // welcome

        // A viewer's pin over HTTP.
        auto r = http(server.port, "POST", base + "/annotations", t.viewer, R"({"kind": "pin", "points": [[100.5, 40]], "text": "too hot"})",
                      {{"X-Dfb-Name", "vera"}});
        ASSERT_EQ(r.status, 200) << r.body;
        json pin = r.json();
        EXPECT_EQ(pin["id"], 1);
        EXPECT_EQ(pin["by"], "vera");
        EXPECT_EQ(pin["rigVersion"], 1);
        EXPECT_EQ(pin["text"], "too hot");
        EXPECT_EQ(pin["resolved"], false);
        json told = watcher.nextText({"presence", "frame", "change"});
        ASSERT_EQ(told["type"], "annotations") << told.dump();
        ASSERT_EQ(told["annotations"].size(), 1u);
        EXPECT_EQ(told["annotations"][0], pin);

        // An edit, then a stroke over the WebSocket from the viewer: it carries the new version.
        ASSERT_EQ(http(server.port, "POST", base + "/edits", t.editor, R"({"changes": [{"path": "key.intensity", "value": 3}]})").status, 200);
        reviewer.send(json{{"type", "annotate"}, {"seq", 4}, {"kind", "stroke"}, {"points", {{10, 10}, {20, 15}, {30, 12}}}, {"color", "#ff0000"}});
        json ack = reviewer.nextText({"presence", "change", "annotations"});
        ASSERT_EQ(ack["type"], "ack") << ack.dump();
        EXPECT_EQ(ack["seq"], 4);
        EXPECT_EQ(ack["annotation"]["id"], 2);
        EXPECT_EQ(ack["annotation"]["by"], "rita");
        EXPECT_EQ(ack["annotation"]["rigVersion"], 2);
        EXPECT_EQ(ack["annotation"]["color"], "#ff0000");
        told = watcher.nextText({"presence", "change"});
        ASSERT_EQ(told["type"], "annotations") << told.dump();
        EXPECT_EQ(told["annotations"].size(), 2u);

        // Refusals, each naming the field; nothing is added.
        reviewer.send(json{{"type", "annotate"}, {"seq", 5}, {"kind", "pin"}, {"points", {{321, 10}}}, {"text", "off"}});
        json err = reviewer.nextText({"presence", "change", "annotations"});
        EXPECT_EQ(err["type"], "error");
        EXPECT_EQ(err["seq"], 5);
        EXPECT_NE(err["message"].get<std::string>().find("outside the 320x180 shot"), std::string::npos) << err.dump();
        r = http(server.port, "POST", base + "/annotations", t.viewer, R"({"kind": "pin", "points": [[1, 1]]})");
        EXPECT_EQ(r.status, 400) << r.body;
        EXPECT_NE(r.body.find("annotation.text: a pin needs a comment"), std::string::npos) << r.body;
        r = http(server.port, "POST", base + "/annotations", t.viewer, R"({"kind": "stroke", "points": [[1, 1]]})");
        EXPECT_EQ(r.status, 400) << r.body;
        EXPECT_NE(r.body.find("2..2000 points"), std::string::npos) << r.body;

        // Resolve and reopen: any role; delete: editors only.
        r = http(server.port, "POST", base + "/annotations/1/resolve", t.viewer, "", {{"X-Dfb-Name", "vera"}});
        ASSERT_EQ(r.status, 200) << r.body;
        EXPECT_EQ(r.json()["resolved"], true);
        EXPECT_EQ(r.json()["resolvedBy"], "vera");
        told = watcher.nextText({"presence", "change"});
        EXPECT_EQ(told["annotations"][0]["resolved"], true) << told.dump();
        r = http(server.port, "DELETE", base + "/annotations/2", t.viewer);
        EXPECT_EQ(r.status, 403) << r.body;
        r = http(server.port, "POST", base + "/annotations/9/resolve", t.viewer);
        EXPECT_EQ(r.status, 404) << r.body;
        r = http(server.port, "POST", base + "/annotations/1/frobnicate", t.viewer);
        EXPECT_EQ(r.status, 404) << r.body;
        ASSERT_EQ(http(server.port, "POST", base + "/annotations", t.editor, R"({"kind": "pin", "points": [[5, 5]], "text": "gone soon"})").status, 200);
        ASSERT_EQ(http(server.port, "DELETE", base + "/annotations/3", t.editor).status, 200);
        EXPECT_FALSE(std::filesystem::exists(state / id / "annotations" / "3.json"));
        kept = http(server.port, "GET", base + "/annotations", t.viewer).json()["annotations"];
        ASSERT_EQ(kept.size(), 2u) << kept.dump();
    }
    std::ofstream(state / id / "annotations" / "17.json") << "{\"id\": 17, ";
    {
        dfb::test::Server server({SHOT, "--state", state.string()});
        ASSERT_TRUE(server.up()) << server.process->output();
        EXPECT_NE(server.process->output().find("17.json: skipped: not JSON"), std::string::npos) << server.process->output();
        const auto& t = server.tokens[id];
        const std::string base = "/v1/sessions/" + id;
        EXPECT_EQ(http(server.port, "GET", base + "/annotations", t.viewer).json()["annotations"], kept);
        auto r = http(server.port, "POST", base + "/annotations/1/reopen", t.viewer);
        ASSERT_EQ(r.status, 200) << r.body;
        EXPECT_EQ(r.json()["resolved"], false);
        EXPECT_FALSE(r.json().contains("resolvedBy"));
        auto next = http(server.port, "POST", base + "/annotations", t.viewer, R"({"kind": "pin", "points": [[5, 5]], "text": "after"})");
        ASSERT_EQ(next.status, 200) << next.body;
        EXPECT_EQ(next.json()["id"], 18) << "past the damaged file's id";
    }
    std::filesystem::remove_all(state);
}
