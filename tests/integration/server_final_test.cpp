// Final renders over the wire (issue 19 point 8): a real dfb-server over loopback runs Cycles
// (Debian's blender, headless) for POST /v1/sessions/ID/final. Progress reaches every WebSocket
// client as `final` messages; the result is fetched as EXR (the shot's size, the preview's scale)
// and PNG; a second request for the same version joins the render, one for another version while
// it runs is refused; DELETE cancels it and no Blender is left running; the time limit stops it
// with an error naming --final-timeout; viewers, bad bodies and missing results are refused.

#include "support/NetClient.h"
#include "support/Process.h"
#include "support/TestServer.h"

#include <dfb/server/ImageCodec.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>

using namespace std::chrono_literals;
using json = nlohmann::json;

namespace {

const std::string SHOT = DFB_TEST_DATA "/tabletop_320.exr";

// Blender processes running dfb_final.py (pgrep's count).
int blenderRenders() {
    FILE* p = ::popen("pgrep -fc 'dfb_final[.]py' 2>/dev/null", "r");
    int n = 0;
    if (p) {
        if (std::fscanf(p, "%d", &n) != 1) n = 0;
        ::pclose(p);
    }
    return n;
}

// The Blender renders still running after up to 5 s: a killed child takes a moment to go away
// on a loaded machine (0 at once is the usual case).
int blenderRendersAfterAWhile() {
    int n = blenderRenders();
    for (int i = 0; i < 50 && n != 0; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        n = blenderRenders();
    }
    return n;
}

// Reads `final` messages until one in `state` (or a failure) arrives.
json untilState(dfb::test::WsClient& ws, const std::string& state, std::vector<json>* seen = nullptr) {
    for (;;) {
        json m = ws.nextText({"presence", "change", "ack"});
        if (m.value("type", "") != "final") continue;
        if (seen) seen->push_back(m);
        if (m["state"] == state || m["state"] == "failed") return m;
    }
}

} // namespace

class ServerFinal : public ::testing::Test {
protected:
    void SetUp() override { ASSERT_TRUE(std::filesystem::exists(SHOT)) << "run the bake_tabletop_fixture test first"; }
};

TEST_F(ServerFinal, RendersWithProgressAndServesTheResult) {
    dfb::test::Server server({SHOT});
    ASSERT_TRUE(server.up()) << server.process->output();
    const std::string id = server.onlySession(), base = "/v1/sessions/" + id + "/final";
    const auto& tk = server.tokens[id];
    dfb::test::WsClient viewer(server.port, id, tk.viewer);

    EXPECT_EQ(server.get(base, tk.viewer).json()["state"], "none");
    EXPECT_EQ(server.get(base + ".exr", tk.viewer).status, 409) << "nothing rendered yet";
    EXPECT_EQ(dfb::test::http(server.port, "POST", base, tk.viewer, "{}").status, 403);
    EXPECT_EQ(dfb::test::http(server.port, "POST", base, tk.editor, R"({"samples": "many"})").status, 400);
    EXPECT_EQ(dfb::test::http(server.port, "POST", base, tk.editor, R"({"samples": 100000})").status, 400) << "over --final samples limit";

    auto post = dfb::test::http(server.port, "POST", base, tk.editor, R"({"samples": 8, "directOnly": true})");
    ASSERT_EQ(post.status, 202) << post.body;
    EXPECT_EQ(post.json()["rigVersion"], 1);
    // Two editors asking at once get one render: the second request joins the first.
    auto again = dfb::test::http(server.port, "POST", base, tk.editor, R"({"samples": 8, "directOnly": true})");
    ASSERT_EQ(again.status, 202) << again.body;
    EXPECT_NE(again.json()["state"], "none");
    std::vector<json> seen;
    const json done = untilState(viewer, "done", &seen);
    ASSERT_EQ(done["state"], "done") << done.dump();
    EXPECT_EQ(done["samples"], json({8, 8}));
    bool progress = false;
    for (const json& m : seen) progress |= m["state"] == "running" && m["samples"][0] > 0 && m["samples"][0] < 8;
    EXPECT_TRUE(progress) << "a running message with samples between 0 and 8";

    auto exr = server.get(base + ".exr", tk.viewer);
    ASSERT_EQ(exr.status, 200) << exr.body;
    EXPECT_EQ(exr.headers["Content-Type"], "image/x-exr");
    const std::string path = (std::filesystem::temp_directory_path() / ("dfb_final_" + std::to_string(::getpid()) + ".exr")).string();
    std::ofstream(path, std::ios::binary) << exr.body;
    auto img = dfb::readLinearImage(path);
    std::filesystem::remove(path);
    ASSERT_TRUE(img.ok()) << img.error().toString();
    EXPECT_EQ(img->width, 320);
    EXPECT_EQ(img->height, 180);
    double sum = 0;
    for (size_t i = 0; i < img->rgba.size(); i += 4) sum += img->rgba[i];
    EXPECT_GT(sum / (320.0 * 180.0), 0.01) << "the default rig lights the render";
    auto png = server.get(base + ".png", tk.viewer);
    ASSERT_EQ(png.status, 200);
    EXPECT_EQ(png.headers["Content-Type"], "image/png");
    EXPECT_EQ(png.headers["ETag"], "\"1\"");
    // Asking again for the same version gives the kept result.
    auto cached = dfb::test::http(server.port, "POST", base, tk.editor, R"({"samples": 8, "directOnly": true})");
    EXPECT_EQ(cached.json()["state"], "done");
    EXPECT_EQ(blenderRendersAfterAWhile(), 0);
}

TEST_F(ServerFinal, CancelAndATimeLimitLeaveNoBlenderBehind) {
    dfb::test::Server server({SHOT, "--final-timeout", "3"});
    ASSERT_TRUE(server.up()) << server.process->output();
    const std::string id = server.onlySession(), base = "/v1/sessions/" + id + "/final";
    const auto& tk = server.tokens[id];
    dfb::test::WsClient editor(server.port, id, tk.editor);

    ASSERT_EQ(dfb::test::http(server.port, "POST", base, tk.editor, R"({"samples": 4096})").status, 202);
    untilState(editor, "running");
    // Another version while it runs: refused, the render goes on.
    auto edit = dfb::test::http(server.port, "POST", "/v1/sessions/" + id + "/edits", tk.editor,
                                R"({"changes": [{"path": "key.intensity", "value": 30}]})");
    ASSERT_EQ(edit.status, 200) << edit.body;
    auto other = dfb::test::http(server.port, "POST", base, tk.editor, R"({"samples": 4096})");
    EXPECT_EQ(other.status, 409) << other.body;
    EXPECT_NE(other.body.find("cancel it first"), std::string::npos) << other.body;
    auto cancel = dfb::test::http(server.port, "DELETE", base, tk.editor);
    ASSERT_EQ(cancel.status, 200) << cancel.body;
    EXPECT_EQ(cancel.json()["state"], "cancelled");
    EXPECT_EQ(untilState(editor, "cancelled")["state"], "cancelled");
    EXPECT_EQ(blenderRendersAfterAWhile(), 0) << "the child was killed";
    EXPECT_EQ(dfb::test::http(server.port, "DELETE", base, tk.editor).status, 409) << "nothing to cancel";

    // Full global illumination at 4096 samples takes far over 3 s here: stopped at the limit.
    ASSERT_EQ(dfb::test::http(server.port, "POST", base, tk.editor, R"({"samples": 4096})").status, 202);
    const json failed = untilState(editor, "done");
    ASSERT_EQ(failed["state"], "failed") << failed.dump();
    EXPECT_NE(failed["error"].get<std::string>().find("--final-timeout"), std::string::npos) << failed.dump();
    EXPECT_EQ(failed["rigVersion"], 2);
    EXPECT_EQ(blenderRendersAfterAWhile(), 0);
    // The session kept serving.
    EXPECT_EQ(server.get("/v1/sessions/" + id + "/rig", tk.viewer).status, 200);
}

TEST_F(ServerFinal, AMissingBlenderIsAClearError) {
    dfb::test::Server server({SHOT, "--blender", "/nonexistent/blender"});
    ASSERT_TRUE(server.up()) << server.process->output();
    const std::string id = server.onlySession(), base = "/v1/sessions/" + id + "/final";
    const auto& tk = server.tokens[id];
    dfb::test::WsClient editor(server.port, id, tk.editor);
    ASSERT_EQ(dfb::test::http(server.port, "POST", base, tk.editor, "").status, 202);
    const json failed = untilState(editor, "done");
    ASSERT_EQ(failed["state"], "failed");
    EXPECT_NE(failed["error"].get<std::string>().find("cannot start Blender"), std::string::npos) << failed.dump();
}

TEST_F(ServerFinal, TheCommandLineClientRendersAndSaves) {
    dfb::test::Server server({SHOT});
    ASSERT_TRUE(server.up()) << server.process->output();
    const std::string id = server.onlySession();
    const auto& tk = server.tokens[id];
    const std::string url = "http://127.0.0.1:" + server.port + "/?session=" + id + "&token=" + tk.editor;
    const std::string out = (std::filesystem::temp_directory_path() / ("dfb_cli_final_" + std::to_string(::getpid()) + ".exr")).string();

    auto [rc, text] = dfb::test::run({DFB_CLIENT_EXE, "final", out, "--samples", "4", "--direct-only", "--server", url});
    ASSERT_EQ(rc, 0) << text;
    EXPECT_NE(text.find("final: running"), std::string::npos) << "progress on stderr: " << text;
    EXPECT_NE(text.find("saved " + out + " (rig version 1"), std::string::npos) << text;
    auto img = dfb::readLinearImage(out);
    std::filesystem::remove(out);
    ASSERT_TRUE(img.ok()) << img.error().toString();
    EXPECT_EQ(img->width, 320);
    EXPECT_EQ(img->height, 180);

    // The same version again: the kept render, saved as PNG without rendering.
    const std::string png = out + ".png";
    auto [rc2, text2] = dfb::test::run({DFB_CLIENT_EXE, "final", png, "--samples", "4", "--direct-only", "--server", url});
    ASSERT_EQ(rc2, 0) << text2;
    EXPECT_EQ(text2.find("final: running"), std::string::npos) << "no second render: " << text2;
    std::ifstream in(png, std::ios::binary);
    char magic[4] = {};
    in.read(magic, 4);
    EXPECT_EQ(std::string(magic + 1, 3), "PNG");
    std::filesystem::remove(png);

    auto [rc3, status] = dfb::test::run({DFB_CLIENT_EXE, "final", "--status", "--server", url});
    ASSERT_EQ(rc3, 0) << status;
    EXPECT_NE(status.find("final render: done, rig version 1"), std::string::npos) << status;
    auto [rc4, bad] = dfb::test::run({DFB_CLIENT_EXE, "final", out + ".tif", "--server", url});
    EXPECT_EQ(rc4, 1) << bad;
    EXPECT_NE(bad.find("must end in .exr or .png"), std::string::npos) << bad;
    auto [rc5, none] = dfb::test::run({DFB_CLIENT_EXE, "final", "--cancel", "--server", url});
    EXPECT_EQ(rc5, 3) << "nothing runs: the server's refusal: " << none;
}
