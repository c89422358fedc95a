// Hostile and oversized input against a real dfb-server over loopback (issue 14): JSON nested
// 100,000 levels deep from viewers and editors, over WebSocket and HTTP; rigs over the light,
// key and memory limits; too many clients and connections; oversized headers and URLs; uniform
// answers for unknown sessions; no server paths in errors; a damaged journal that refuses its
// own session while the others serve. After each, the server keeps serving.

#include "support/NetClient.h"
#include "support/Process.h"
#include "support/TestServer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

#include <sys/mount.h>
#include <unistd.h>

using namespace dfb;
using namespace std::chrono_literals;
using json = nlohmann::json;
using test::Server;

namespace {

const std::string SHOT = DFB_TEST_DATA "/tabletop_320.exr";
const std::string ID = "tabletop_320";

std::string nested(int depth) { return std::string(size_t(depth), '[') + "1" + std::string(size_t(depth), ']'); }

std::filesystem::path tempDir(const std::string& what) {
    auto d = std::filesystem::temp_directory_path() / ("dfb_limits_" + what + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    return d;
}

// The next error message on a WebSocket (acks, changes and presence skipped).
json nextError(test::WsClient& c) {
    for (;;) {
        json m = c.nextText({"presence", "change"});
        if (m["type"] == "error") return m;
    }
}

std::string slurp(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

} // namespace

TEST(Limits, DeeplyNestedJsonFromAnyClientIsRefusedAndTheServerServes) {
    Server server({SHOT});
    ASSERT_TRUE(server.up()) << server.process->output();
    const auto& tk = server.tokens[ID];
    const uint64_t version = server.rig(ID)["version"];
    const std::string deep = nested(100000); // 200 KB: under the 1 MiB message limit

    test::WsClient viewer(server.port, ID, tk.viewer);
    ASSERT_EQ(viewer.nextText()["type"], "welcome");
    for (const char* field : {"encoding", "viewTransform"}) {
        viewer.send(std::string(R"({"type":"view","seq":7,")") + field + "\":" + deep + "}");
        const json e = nextError(viewer);
        EXPECT_EQ(e["code"], "limit_exceeded") << e;
        EXPECT_LT(e["message"].get<std::string>().size(), 200u) << e;
    }
    test::WsClient editor(server.port, ID, tk.editor);
    ASSERT_EQ(editor.nextText()["type"], "welcome");
    for (const char* path : {"viewTransform", "key.type", "key.intensity"}) {
        editor.send(std::string(R"({"type":"edit","seq":3,"changes":[{"path":")") + path + "\",\"value\":" + deep + "}]}");
        const json e = nextError(editor);
        EXPECT_EQ(e["code"], "limit_exceeded") << e;
    }
    // The viewer may not edit, deep or not.
    viewer.send(std::string(R"({"type":"edit","seq":4,"changes":[{"path":"key.type","value":)") + deep + "}]}");
    EXPECT_EQ(nextError(viewer)["code"], "limit_exceeded");

    // HTTP: edits and a rig with the same values, editor and viewer tokens.
    const std::string base = "/v1/sessions/" + ID;
    for (const std::string* token : {&tk.editor, &tk.viewer}) {
        auto r = test::http(server.port, "POST", base + "/edits", *token,
                            R"({"changes":[{"path":"key.intensity","value":)" + deep + "}]}");
        EXPECT_GE(r.status, 400) << r.body;
        EXPECT_LT(r.body.size(), 400u) << r.body.substr(0, 400);
        auto put = test::http(server.port, "PUT", base + "/rig", *token, R"({"lights":)" + deep + "}");
        EXPECT_GE(put.status, 400) << put.body.substr(0, 400);
        EXPECT_LT(put.body.size(), 400u);
    }
    auto r = test::http(server.port, "POST", base + "/edits", tk.editor, R"({"changes":[{"path":"key.intensity","value":)" + deep + "}]}");
    EXPECT_EQ(r.status, 400);
    EXPECT_EQ(r.json()["code"], "limit_exceeded") << r.body;
    // A deep value that is not JSON at all, and a deep object.
    std::string objects;
    for (int i = 0; i < 100000; ++i) objects += "{\"a\":";
    editor.send(R"({"type":"edit","seq":5,"changes":[{"path":"key.position","value":)" + objects);
    EXPECT_NE(nextError(editor)["code"], "");

    // Still serving: health, a new client's welcome, edits, and nothing was changed.
    EXPECT_EQ(server.get("/healthz", "").status, 200);
    test::WsClient late(server.port, ID, tk.editor);
    EXPECT_EQ(late.nextText()["type"], "welcome");
    EXPECT_EQ(server.rig(ID)["version"], version);
    late.send(json{{"type", "edit"}, {"seq", 9}, {"changes", {{{"path", "key.intensity"}, {"value", 90}}}}});
    const json ack = late.nextText({"presence", "change"});
    EXPECT_EQ(ack["type"], "ack") << ack;
    EXPECT_EQ(ack["rigVersion"], version + 1);
}

TEST(Limits, RigsOverALimitAreRefusedAndARigAtTheLimitRenders) {
    Server server({SHOT});
    ASSERT_TRUE(server.up()) << server.process->output();
    const std::string token = server.tokens[ID].editor, base = "/v1/sessions/" + ID;
    const json before = server.rig(ID);
    const size_t historyBefore = server.get(base + "/history", token).json()["entries"].size();

    // The 10,000-light PUT of the hostile test (~200 KB: under the body limit).
    json many = {{"lights", json::array()}};
    for (int i = 0; i < 10000; ++i) many["lights"].push_back({{"name", "l" + std::to_string(i)}});
    auto r = test::http(server.port, "PUT", base + "/rig", token, many.dump());
    ASSERT_EQ(r.status, 400) << r.body.substr(0, 300);
    EXPECT_EQ(r.json()["code"], "limit_exceeded");
    EXPECT_NE(r.json()["message"].get<std::string>().find("256 lights"), std::string::npos) << r.body;
    EXPECT_EQ(server.rig(ID), before);
    EXPECT_EQ(server.get(base + "/history", token).json()["entries"].size(), historyBefore); // nothing journaled

    // At the limit: 256 shadowed spots with small maps render.
    json full = {{"lights", json::array()}};
    for (int i = 0; i < 256; ++i) {
        const double a = i * 0.0245;
        full["lights"].push_back({{"name", "s" + std::to_string(i)},
                                  {"position", {3 * std::cos(a), 3, 3 * std::sin(a)}},
                                  {"direction", {-std::cos(a), -1, -std::sin(a)}},
                                  {"intensity", 0.5},
                                  {"shadowMapSize", 64}});
    }
    r = test::http(server.port, "PUT", base + "/rig", token, full.dump());
    ASSERT_EQ(r.status, 200) << r.body.substr(0, 300);
    const uint64_t v = r.json()["rigVersion"];
    auto frame = server.get(base + "/frame?format=png", token);
    ASSERT_EQ(frame.status, 200) << frame.body.substr(0, 300);
    EXPECT_EQ(frame.headers["X-Rig-Version"], std::to_string(v));
    // One more light through an edit of the whole list is over the limit again.
    json more = full["lights"];
    more.push_back({{"name", "extra"}});
    full["lights"] = more;
    r = test::http(server.port, "PUT", base + "/rig", token, full.dump());
    EXPECT_EQ(r.json()["code"], "limit_exceeded") << r.body.substr(0, 300);

    // Memory: 256 maps of 8192^2 (64 GiB) through one edit of each light is refused whole.
    json changes = json::array();
    for (int i = 0; i < 256; ++i) changes.push_back({{"path", "s" + std::to_string(i) + ".shadowMapSize"}, {"value", 8192}});
    r = test::http(server.port, "POST", base + "/edits", token, json{{"changes", changes}}.dump());
    ASSERT_EQ(r.status, 400) << r.body;
    EXPECT_EQ(r.json()["code"], "limit_exceeded");
    EXPECT_NE(r.json()["message"].get<std::string>().find("--max-light-memory-mb"), std::string::npos) << r.body;
    EXPECT_EQ(server.rig(ID)["version"], v);
}

TEST(Limits, ClientsPerSessionAndConnectionsPerAddress) {
    Server server({SHOT, "--max-clients-per-session", "2", "--max-connections-per-address", "4"});
    ASSERT_TRUE(server.up()) << server.process->output();
    const auto& tk = server.tokens[ID];
    {
        test::WsClient a(server.port, ID, tk.viewer), b(server.port, ID, tk.editor);
        ASSERT_EQ(a.nextText()["type"], "welcome");
        ASSERT_EQ(b.nextText()["type"], "welcome");
        test::WsClient c(server.port, ID, tk.viewer);
        EXPECT_THROW(
            for (;;) c.readOne(), std::exception);
        EXPECT_EQ(int(c.closeReason().code), 1013);
        const std::string why(c.closeReason().reason.data(), c.closeReason().reason.size());
        EXPECT_NE(why.find("--max-clients-per-session"), std::string::npos) << why;
        // The two admitted clients still work.
        b.send(json{{"type", "edit"}, {"seq", 1}, {"changes", {{{"path", "key.intensity"}, {"value", 70}}}}});
        EXPECT_EQ(b.nextText({"presence", "change"})["type"], "ack");
    }
    // Connections from one address: four idle ones hold every slot; a fifth is answered 503.
    // First every earlier connection must have given its slot back: only this request's is open.
    auto openConnections = [&] {
        const std::string m = server.get("/metrics", "").body;
        const size_t at = m.find("\ndfb_connections_open ");
        return at == std::string::npos ? -1 : std::stoi(m.substr(at + 22));
    };
    for (int i = 0; i < 300 && openConnections() != 1; ++i) std::this_thread::sleep_for(20ms);
    ASSERT_EQ(openConnections(), 1);
    boost::asio::io_context ioc;
    std::vector<std::unique_ptr<boost::asio::ip::tcp::socket>> idle;
    for (int i = 0; i < 4; ++i) {
        idle.push_back(std::make_unique<boost::asio::ip::tcp::socket>(ioc));
        idle.back()->connect({boost::asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(std::stoi(server.port))});
    }
    // The server accepts them in its own time: ask until it refuses (the deadline ends a failure).
    test::HttpReply refused;
    for (int i = 0; i < 300 && refused.status != 503; ++i) {
        refused = server.get("/healthz", "");
        if (refused.status != 503) std::this_thread::sleep_for(20ms);
    }
    EXPECT_EQ(refused.status, 503) << refused.body;
    EXPECT_EQ(refused.json()["code"], "limit_exceeded");
    EXPECT_NE(refused.json()["message"].get<std::string>().find("--max-connections-per-address"), std::string::npos);
    EXPECT_FALSE(refused.headers["Retry-After"].empty());
    // One idle connection goes: once the server has seen it close, requests are served again.
    idle.pop_back();
    idle.back()->close(); // and a second, so that this poll's own lingering connections fit
    idle.pop_back();
    int status = 0;
    for (int i = 0; i < 300 && status != 200; ++i) {
        status = server.get("/healthz", "").status;
        if (status != 200) std::this_thread::sleep_for(20ms);
    }
    EXPECT_EQ(status, 200);
    idle.clear();
    // The refused client and the refused connection(s) are counted.
    std::string metrics;
    for (int i = 0; i < 300 && metrics.find("dfb_connections_refused_total") == std::string::npos; ++i) {
        metrics = server.get("/metrics", "").body;
        if (metrics.find("dfb_connections_refused_total") == std::string::npos) std::this_thread::sleep_for(20ms);
    }
    const size_t at = metrics.find("\ndfb_connections_refused_total ");
    ASSERT_NE(at, std::string::npos) << metrics;
    EXPECT_GE(std::stoi(metrics.substr(at + 31)), 2) << metrics;
}

TEST(Limits, OversizedHeadersAndUrlsGet431And414) {
    Server server({SHOT});
    ASSERT_TRUE(server.up()) << server.process->output();
    auto headers = test::http(server.port, "GET", "/healthz", "", "", {{"X-Filler", std::string(17000, 'a')}});
    EXPECT_EQ(headers.status, 431) << headers.body;
    EXPECT_EQ(headers.json()["code"], "limit_exceeded");
    auto url = test::http(server.port, "GET", "/v1/sessions/" + ID + "/frame?output=" + std::string(20000, 'b'), "");
    EXPECT_EQ(url.status, 414) << url.body;
    auto urlUnderHeaders = test::http(server.port, "GET", "/healthz?x=" + std::string(9000, 'c'), "");
    EXPECT_EQ(urlUnderHeaders.status, 414) << urlUnderHeaders.body;
    EXPECT_EQ(server.get("/healthz", "").status, 200);
}

TEST(Limits, UniformAnswersAndNoServerPathsInErrors) {
    Server server({SHOT, "--metrics-session-names=false"});
    ASSERT_TRUE(server.up()) << server.process->output();
    const auto& tk = server.tokens[ID];
    // An unknown session and a wrong token: the same status and the same kind of message.
    auto unknown = server.get("/v1/sessions/nosuch/rig", tk.editor);
    auto wrong = server.get("/v1/sessions/" + ID + "/rig", "x" + tk.editor);
    EXPECT_EQ(unknown.status, 401);
    EXPECT_EQ(wrong.status, 401);
    EXPECT_EQ(unknown.json()["code"], wrong.json()["code"]);
    EXPECT_EQ(unknown.json()["message"].get<std::string>(),
              std::regex_replace(wrong.json()["message"].get<std::string>(), std::regex(ID), "nosuch"));
    EXPECT_THROW(test::WsClient(server.port, "nosuch", tk.editor), std::exception);

    // No session names in /metrics.
    const std::string metrics = server.get("/metrics", "").body;
    EXPECT_EQ(metrics.find("session=\""), std::string::npos) << metrics;
    EXPECT_NE(metrics.find("dfb_changes_total "), std::string::npos) << metrics;

    // A cookie that is not there: the error names the cookie, not where the assets are.
    auto r = test::http(server.port, "POST", "/v1/sessions/" + ID + "/edits", tk.editor,
                        R"({"changes":[{"path":"key.cookie","value":"missing.png"}]})");
    EXPECT_EQ(r.status, 400) << r.body;
    const std::string message = r.json()["message"];
    EXPECT_NE(message.find("missing.png"), std::string::npos) << message;
    EXPECT_EQ(message.find(std::filesystem::path(SHOT).parent_path().string()), std::string::npos) << message;
    EXPECT_EQ(message.find("/tmp"), std::string::npos) << message;
    EXPECT_EQ(message.find("//"), std::string::npos) << message;

    // Out-of-range protocol versions.
    test::WsClient c(server.port, ID, tk.viewer);
    ASSERT_EQ(c.nextText()["type"], "welcome");
    c.send(std::string(R"({"type":"hello","protocol":4294967297})"));
    const json e = nextError(c);
    EXPECT_EQ(e["code"], "protocol");
    EXPECT_NE(e["message"].get<std::string>().find("4294967297"), std::string::npos) << e;
}

TEST(Limits, ADamagedJournalRefusesOnlyItsSession) {
    const auto state = tempDir("state");
    {
        Server first({"--session", "alpha=" + SHOT, "--session", "beta=" + SHOT, "--state", state.string()});
        ASSERT_TRUE(first.up()) << first.process->output();
        for (const char* s : {"alpha", "beta"}) {
            for (int i = 0; i < 3; ++i) {
                auto r = test::http(first.port, "POST", std::string("/v1/sessions/") + s + "/edits", first.tokens[s].editor,
                                    json{{"changes", {{{"path", "key.intensity"}, {"value", 60 + i}}}}}.dump());
                ASSERT_EQ(r.status, 200) << r.body;
            }
        }
    }
    // Damage alpha's journal before its end: a changed line in the middle.
    const auto journal = state / "alpha" / "journal.jsonl";
    std::string text = slurp(journal);
    const size_t second = text.find('\n') + 1;
    text.insert(second, "this is not a journal record\n");
    std::ofstream(journal, std::ios::binary | std::ios::trunc) << text;

    Server server({"--session", "alpha=" + SHOT, "--session", "beta=" + SHOT, "--state", state.string()});
    ASSERT_TRUE(server.up()) << server.process->output();
    EXPECT_NE(server.process->output().find("journal.jsonl:2"), std::string::npos) << server.process->output();
    // beta serves, with its history.
    auto b = server.get("/v1/sessions/beta/rig", server.tokens["beta"].editor);
    ASSERT_EQ(b.status, 200);
    EXPECT_EQ(b.json()["version"], 4);
    auto e = test::http(server.port, "POST", "/v1/sessions/beta/edits", server.tokens["beta"].editor,
                        R"({"changes":[{"path":"key.intensity","value":33}]})");
    EXPECT_EQ(e.status, 200) << e.body;
    // alpha answers 503 "unavailable" with the reason (no server folders), to its own tokens.
    ASSERT_FALSE(server.tokens["alpha"].editor.empty()) << server.process->output();
    auto a = server.get("/v1/sessions/alpha/rig", server.tokens["alpha"].editor);
    EXPECT_EQ(a.status, 503) << a.body;
    EXPECT_EQ(a.json()["code"], "unavailable");
    EXPECT_NE(a.json()["message"].get<std::string>().find(":2"), std::string::npos) << a.body;
    EXPECT_EQ(a.json()["message"].get<std::string>().find(state.string()), std::string::npos) << a.body;
    EXPECT_FALSE(a.headers["Retry-After"].empty());
    EXPECT_EQ(server.get("/v1/sessions/alpha/rig", server.tokens["beta"].editor).status, 401);
    EXPECT_THROW(test::WsClient(server.port, "alpha", server.tokens["alpha"].editor), std::exception);
    auto list = server.get("/v1/sessions", server.tokens["alpha"].viewer).json();
    ASSERT_EQ(list["sessions"].size(), 1u) << list;
    EXPECT_EQ(list["sessions"][0]["state"], "failed");
    // The damaged journal is left as it was, for the operator.
    EXPECT_EQ(slurp(journal), text);
    std::filesystem::remove_all(state);
}

TEST(Limits, AFullDiskRefusesEditsOfItsSessionAndLosesNothing) {
    // alpha's folder is a 256 KiB tmpfs; beta's is on the ordinary disk beside it.
    const auto state = tempDir("enospc");
    const auto alphaDir = state / "alpha";
    std::filesystem::create_directories(alphaDir);
    if (::geteuid() != 0 || ::mount("tmpfs", alphaDir.c_str(), "tmpfs", 0, "size=256k") != 0) {
        std::filesystem::remove_all(state);
        GTEST_SKIP() << "cannot mount a tmpfs (needs root)";
    }
    struct Unmount {
        std::filesystem::path dir;
        ~Unmount() { ::umount2(dir.c_str(), MNT_DETACH); }
    } unmount{alphaDir};
    const std::vector<std::string> args = {"--session", "alpha=" + SHOT, "--session", "beta=" + SHOT, "--state", state.string()};
    std::vector<int> acked; // the intensities alpha acknowledged, in order
    uint64_t lastVersion = 0;
    {
        Server server(args);
        ASSERT_TRUE(server.up()) << server.process->output();
        auto post = [&](const std::string& s, int value) {
            return test::http(server.port, "POST", "/v1/sessions/" + s + "/edits", server.tokens[s].editor,
                              json{{"changes", {{{"path", "key.intensity"}, {"value", value}}}}}.dump());
        };
        auto ok = post("alpha", 10);
        ASSERT_EQ(ok.status, 200) << ok.body;
        acked.push_back(10);
        // Fill the disk to the last few bytes: the next journal record cannot be written whole.
        {
            std::ofstream filler(alphaDir / "filler", std::ios::binary);
            const std::string block(4096, 'x');
            while (filler.write(block.data(), block.size())) {}
        }
        {
            std::ofstream tail(alphaDir / "filler-tail", std::ios::binary);
            while (tail.put('x')) {}
        }
        // The journal's last page still has room for some records (tmpfs allocates pages).
        int refused = 0;
        for (int i = 0; i < 200 && refused < 3; ++i) {
            auto r = post("alpha", 20 + i);
            if (r.status == 200) {
                acked.push_back(20 + i);
                continue;
            }
            EXPECT_EQ(r.json()["code"], "io_error") << r.body;
            EXPECT_EQ(r.json()["message"].get<std::string>().find(state.string()), std::string::npos) << r.body;
            ++refused;
        }
        EXPECT_GT(refused, 0) << "the full disk refused nothing";
        // beta is on another disk: served as usual meanwhile.
        EXPECT_EQ(post("beta", 44).status, 200);
        // Space comes back: alpha's edits are accepted again.
        std::filesystem::remove(alphaDir / "filler");
        std::filesystem::remove(alphaDir / "filler-tail");
        auto again = post("alpha", 30);
        ASSERT_EQ(again.status, 200) << again.body;
        acked.push_back(30);
        lastVersion = again.json()["rigVersion"];
    }
    // A restart replays every acknowledged edit and nothing else: no fragment in the journal.
    Server server(args);
    ASSERT_TRUE(server.up()) << server.process->output();
    EXPECT_EQ(server.process->output().find("not served"), std::string::npos) << server.process->output();
    const json history = server.get("/v1/sessions/alpha/history", server.tokens["alpha"].editor).json();
    std::vector<int> replayed;
    for (const auto& e : history["entries"]) replayed.push_back(int(e["changes"][0]["value"].get<double>()));
    EXPECT_EQ(replayed, acked);
    EXPECT_EQ(history["rigVersion"], lastVersion);
    EXPECT_EQ(server.rig("beta")["version"], 2);
}
