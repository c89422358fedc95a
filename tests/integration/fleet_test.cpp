// A fleet of dfb-server nodes sharing one sessions and state folder (issue 21, docs/deployment.md):
// sessions opened on request and closed when idle, one lease per session (two nodes never write
// one journal), the drain on SIGTERM, and failover behind a real HAProxy (Debian's haproxy,
// configured by scripts/fleet from deploy/haproxy/) with a node SIGKILLed in the middle of two
// clients' edits. Everything runs on loopback and stops by itself.

#include "support/NetClient.h"
#include "support/Process.h"
#include "support/TestServer.h"

#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <regex>
#include <set>
#include <thread>

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using dfb::test::http;
using dfb::test::HttpReply;
using dfb::test::Process;
using dfb::test::Tokens;
using json = nlohmann::json;

const std::string SHOT = DFB_TEST_DATA "/tabletop_320.exr";

// A folder of its own per test, removed at the end.
struct TempDir {
    explicit TempDir(const std::string& name) : path(fs::temp_directory_path() / ("dfb_fleet_" + name + "_" + std::to_string(::getpid()))) {
        fs::remove_all(path);
        fs::create_directories(path / "sessions");
        fs::create_directories(path / "state");
    }
    ~TempDir() { fs::remove_all(path); }
    fs::path path;
};

// `n` sessions s1..sn, each a copy of the tabletop shot.
void addShots(const fs::path& dir, int n) {
    for (int i = 1; i <= n; ++i) fs::copy_file(SHOT, dir / "sessions" / ("s" + std::to_string(i) + ".exr"), fs::copy_options::overwrite_existing);
}

// One node of the fleet: --sessions and --state in `dir`, a free loopback port.
struct Node {
    Node(const fs::path& dir, const std::string& nodeName, std::vector<std::string> extra = {}) : name(nodeName) {
        std::vector<std::string> args = {DFB_SERVER_EXE, "--sessions", (dir / "sessions").string(), "--state", (dir / "state").string(),
                                         "--node", nodeName, "--port", "0", "--default-rig", "key-fill"};
        args.insert(args.end(), extra.begin(), extra.end());
        process = std::make_unique<Process>(args);
        auto m = process->waitForLine(std::regex(R"(listening on http://127\.0\.0\.1:(\d+)/)"), 60s);
        if (!m) return;
        port = (*m)[1];
        tokens = dfb::test::printedTokens(process->output());
    }
    std::string name;
    std::unique_ptr<Process> process;
    std::string port;
    std::map<std::string, Tokens> tokens;
};

// HTTP that reports a refused connection as status 0 instead of throwing (a node that died).
HttpReply tryHttp(const std::string& port, const std::string& method, const std::string& target, const std::string& token,
                  const std::string& body = "") {
    try {
        return http(port, method, target, token, body);
    } catch (const std::exception&) {
        return {};
    }
}

std::string header(const HttpReply& r, const std::string& name) {
    for (const auto& [k, v] : r.headers) {
        if (k.size() == name.size() && std::equal(k.begin(), k.end(), name.begin(), [](char a, char b) { return std::tolower(a) == std::tolower(b); })) {
            return v;
        }
    }
    return "";
}

double intensityOf(const json& rig, const std::string& light) {
    for (const auto& l : rig["lights"]) {
        if (l.value("name", "") == light) return l["intensity"].get<double>();
    }
    return -1;
}

json sessionEntry(const json& list, const std::string& id) {
    for (const auto& s : list["sessions"]) {
        if (s.value("id", "") == id) return s;
    }
    return nullptr;
}

// The history's value of `path` per version (edits of one property only).
std::map<uint64_t, double> historyValues(const json& history, const std::string& path) {
    std::map<uint64_t, double> out;
    for (const auto& e : history["entries"]) {
        if (e.value("kind", "") != "edit") continue;
        for (const auto& c : e["changes"]) {
            if (c.value("path", "") == path) out[e["version"].get<uint64_t>()] = c["value"].get<double>();
        }
    }
    return out;
}

// Point 1: sessions are opened on their first request and closed when idle; the list shows all.
TEST(Fleet, SessionsOpenOnRequestAreListedAllAndCloseWhenIdle) {
    TempDir dir("lazy");
    addShots(dir.path, 3);
    Node node(dir.path, "n1", {"--idle-close", "2"});
    ASSERT_FALSE(node.port.empty()) << node.process->output();
    ASSERT_EQ(node.tokens.size(), 3u) << "every session's links are printed at start";
    EXPECT_EQ(node.process->output().find("shadow-casting triangles"), std::string::npos) << "nothing is opened at start";
    const Tokens t = node.tokens["s2"];

    json list = http(node.port, "GET", "/v1/sessions", t.editor).json();
    EXPECT_EQ(sessionEntry(list, "s2").value("state", ""), "closed") << list.dump();
    EXPECT_TRUE(sessionEntry(list, "s1").is_null()) << "another session's token lists only its own";

    ASSERT_EQ(http(node.port, "POST", "/v1/sessions/s2/edits", t.editor, R"({"changes": [{"path": "key.intensity", "value": 2.5}]})").status, 200);
    list = http(node.port, "GET", "/v1/sessions", t.editor).json();
    EXPECT_EQ(sessionEntry(list, "s2").value("state", ""), "open");
    EXPECT_EQ(sessionEntry(list, "s2").value("rigVersion", 0), 2);
    // A new shot in the folder (a batch bake) is listed without a restart.
    fs::copy_file(SHOT, dir.path / "sessions" / "s9.exr");
    list = http(node.port, "GET", "/v1/sessions", node.tokens["s1"].editor).json();
    // The new session's tokens are made when it is first listed (tokens.json in its state folder).
    EXPECT_TRUE(fs::exists(dir.path / "state" / "s9" / "tokens.json"));

    // Idle for --idle-close 2 s: closed (lease released), the journal kept.
    ASSERT_TRUE(node.process->waitForLine(std::regex("session s2 closed on this node: closed after being idle"), 10s)) << node.process->output();
    list = http(node.port, "GET", "/v1/sessions", t.editor).json();
    EXPECT_EQ(sessionEntry(list, "s2").value("state", ""), "closed") << list.dump();
    EXPECT_TRUE(fs::exists(dir.path / "state" / "s2" / "journal.jsonl"));
    // Reopened on the next request with the journal replayed.
    const json rig = http(node.port, "GET", "/v1/sessions/s2/rig", t.viewer).json();
    EXPECT_EQ(rig.value("version", 0), 2);
    EXPECT_DOUBLE_EQ(intensityOf(rig, "key"), 2.5) << rig.dump();

    // A new shot of the session's name (a batch bake writes it beside and renames it into place)
    // is what the session opens next time, with its rig and history kept.
    const fs::path baked = dir.path / "s2.exr.new";
    auto [bakeRc, bakeOut] = dfb::test::run({DFB_BAKE_EXE, DFB_SOURCE_DIR "/scenes/tabletop.glb", "-o", baked.string(), "--width", "64",
                                              "--height", "36", "--env-rays", "0"},
                                             120s);
    ASSERT_EQ(bakeRc, 0) << bakeOut;
    // Closed again after the reopening above (waitForLine reads the whole output: count them).
    auto closings = [&] {
        node.process->waitForLine(std::regex("^$^"), 200ms); // reads what arrived
        const std::string& out = node.process->output();
        size_t n = 0;
        for (size_t at = 0; (at = out.find("session s2 closed on this node", at)) != std::string::npos; ++at) ++n;
        return n;
    };
    for (int i = 0; i < 50 && closings() < 2; ++i) {
    }
    ASSERT_EQ(closings(), 2u) << node.process->output();
    fs::rename(baked, dir.path / "sessions" / "s2.exr");
    const json info = http(node.port, "GET", "/v1/sessions/s2", t.viewer).json();
    EXPECT_EQ(info["session"].value("width", 0), 64) << info.dump();
    EXPECT_EQ(info.value("rigVersion", 0), 2) << "the journal is replayed onto the new shot";
    // A token of no session and a session of no shot get the same answer.
    EXPECT_EQ(http(node.port, "GET", "/v1/sessions/nosuch/rig", t.editor).status, 401);
    EXPECT_EQ(http(node.port, "GET", "/v1/sessions/s3/rig", t.editor).status, 401);
}

// A node holds at most --max-open-sessions: one more closes the session idle longest that has no
// client, and when every open one has clients the request is refused, naming the limit.
TEST(Fleet, OpenSessionsAreBounded) {
    TempDir dir("bounded");
    addShots(dir.path, 3);
    Node node(dir.path, "n1", {"--max-open-sessions", "2"});
    ASSERT_FALSE(node.port.empty()) << node.process->output();
    auto rig = [&](const std::string& id) { return http(node.port, "GET", "/v1/sessions/" + id + "/rig", node.tokens[id].viewer); };
    ASSERT_EQ(rig("s1").status, 200);
    std::this_thread::sleep_for(50ms);
    ASSERT_EQ(rig("s2").status, 200);
    ASSERT_EQ(rig("s3").status, 200);
    EXPECT_TRUE(node.process->waitForLine(std::regex("session s1 closed on this node: closed to make room for another \\(--max-open-sessions 2\\)"), 5s))
        << node.process->output();
    // s2 and s3 in use: no room for s1.
    dfb::test::WsClient a(node.port, "s2", node.tokens["s2"].viewer), b(node.port, "s3", node.tokens["s3"].viewer);
    ASSERT_EQ(a.nextText()["type"], "welcome");
    ASSERT_EQ(b.nextText()["type"], "welcome");
    const HttpReply refused = rig("s1");
    EXPECT_EQ(refused.status, 503);
    EXPECT_EQ(refused.json().value("code", ""), "unavailable") << refused.body;
    EXPECT_NE(refused.body.find("--max-open-sessions"), std::string::npos) << refused.body;
    EXPECT_EQ(rig("s2").status, 200) << "the open ones are served";
}

// Point 2: one owner per session. Two nodes take requests for one session at once (no router:
// the worst case); each edit is acknowledged by the lease holder only, the other answers 503
// moved and asks for a handoff, and the session moves between them. Every acknowledged edit is in
// the journal once, and a third node replays it cleanly.
TEST(Fleet, TwoNodesNeverWriteOneJournal) {
    TempDir dir("lease");
    addShots(dir.path, 1);
    Node a(dir.path, "na"), b(dir.path, "nb");
    ASSERT_FALSE(a.port.empty() || b.port.empty());
    ASSERT_EQ(a.tokens["s1"].editor, b.tokens["s1"].editor) << "both nodes hand out the session's one pair of tokens";
    const std::string token = a.tokens["s1"].editor;

    struct Acked {
        uint64_t version;
        double value;
    };
    std::mutex mutex;
    std::vector<Acked> acked;
    std::atomic<int> moved{0};
    // Both edit until each has had the session for a while (20 edits acknowledged each, with a
    // hand-over at least one way), at most 40 s: at ~50 edits a second each the whole run fits
    // the history's 10,000 records. Not a fixed time: a loaded machine opens sessions slowly.
    std::atomic<bool> stop{false};
    std::atomic<int> ackedBy[3] = {0, 0, 0};
    auto editor = [&](const std::string& port, int who) {
        for (int i = 0; !stop; std::this_thread::sleep_for(20ms)) {
            const double value = who * 1000 + i + 1;
            const HttpReply r = tryHttp(port, "POST", "/v1/sessions/s1/edits", token,
                                        R"({"changes": [{"path": "key.intensity", "value": )" + std::to_string(value) + "}]}");
            if (r.status == 200) {
                std::lock_guard lock(mutex);
                acked.push_back({r.json()["rigVersion"].get<uint64_t>(), value});
                ++ackedBy[who];
                ++i;
            } else {
                ASSERT_EQ(r.status, 503) << r.body;
                EXPECT_EQ(r.json().value("code", ""), "moved") << r.body;
                EXPECT_EQ(header(r, "Retry-After"), "1");
                ++moved;
                std::this_thread::sleep_for(80ms);
            }
        }
    };
    std::thread ta(editor, a.port, 1), tb(editor, b.port, 2);
    for (int i = 0; i < 400 && (ackedBy[1] < 20 || ackedBy[2] < 20); ++i) std::this_thread::sleep_for(100ms);
    stop = true;
    ta.join();
    tb.join();
    EXPECT_GT(moved.load(), 0) << "one node at a time holds the session";
    std::set<double> valuesByA, valuesByB;
    for (const Acked& e : acked) (e.value < 2000 ? valuesByA : valuesByB).insert(e.value);
    EXPECT_GE(valuesByA.size(), 20u);
    EXPECT_GE(valuesByB.size(), 20u) << "the session was handed over to the second node";
    a.process->stop();
    b.process->stop();

    Node c(dir.path, "nc");
    const json history = http(c.port, "GET", "/v1/sessions/s1/history", token).json();
    const auto values = historyValues(history, "key.intensity");
    ASSERT_EQ(values.size(), acked.size()) << "every acknowledged edit is journaled, and nothing else";
    std::set<uint64_t> versions;
    for (const Acked& e : acked) {
        EXPECT_TRUE(versions.insert(e.version).second) << "version " << e.version << " acknowledged twice";
        ASSERT_TRUE(values.count(e.version)) << "acknowledged version " << e.version << " is not in the journal";
        EXPECT_DOUBLE_EQ(values.at(e.version), e.value);
    }
    EXPECT_EQ(history.value("rigVersion", 0), acked.size() + 1);
}

// SIGTERM drains: not ready, sessions closed with their leases released, clients told to go
// elsewhere (close 1012), exit 0.
TEST(Fleet, SigtermDrainsTheNode) {
    TempDir dir("drain");
    addShots(dir.path, 1);
    Node a(dir.path, "na");
    const std::string token = a.tokens["s1"].editor;
    ASSERT_EQ(http(a.port, "GET", "/readyz", "").body, "ready\n");
    dfb::test::WsClient ws(a.port, "s1", token);
    ASSERT_EQ(ws.nextText()["type"], "welcome");
    const auto sent = std::chrono::steady_clock::now();
    ::kill(a.process->pid(), SIGTERM);
    ASSERT_TRUE(a.process->waitForLine(std::regex("session s1 closed on this node: this node is shutting down"), 5s)) << a.process->output();
    // While the client is still there the node answers, not ready, and refers session requests on.
    const HttpReply ready = tryHttp(a.port, "GET", "/readyz", "");
    EXPECT_EQ(ready.status, 503) << ready.body;
    const HttpReply rig = tryHttp(a.port, "GET", "/v1/sessions/s1/rig", token);
    EXPECT_EQ(rig.status, 503);
    EXPECT_EQ(rig.json().value("code", ""), "moved") << rig.body;
    // The lease is already released: another node opens the session now.
    Node b(dir.path, "nb");
    EXPECT_EQ(tryHttp(b.port, "GET", "/v1/sessions/s1/rig", token).status, 200);
    // The client hears why (service restart: reconnect).
    try {
        for (;;) ws.readOne();
    } catch (const std::exception&) {
    }
    EXPECT_EQ(ws.closeReason().code, 1012) << ws.closeReason().reason;
    EXPECT_EQ(a.process->wait(10s), 0) << a.process->output();
    EXPECT_LT(std::chrono::steady_clock::now() - sent, 15s) << "the drain waits at most 3 s for clients";
}

// A free loopback port (bound, read, released) for HAProxy's front.
std::string freePort() {
    boost::asio::io_context ioc;
    boost::asio::ip::tcp::acceptor acceptor(ioc, {boost::asio::ip::make_address("127.0.0.1"), 0});
    return std::to_string(acceptor.local_endpoint().port());
}

// HAProxy from the project's template (scripts/fleet --config-for) in front of `nodes`.
struct Router {
    Router(const fs::path& dir, const std::vector<const Node*>& nodes) {
        port = freePort();
        std::vector<std::string> args = {"/bin/bash", DFB_SOURCE_DIR "/scripts/fleet", "--config-for", port};
        for (const Node* n : nodes) args.push_back("127.0.0.1:" + n->port);
        auto [rc, config] = dfb::test::run(args, 30s);
        if (rc != 0) {
            error = "scripts/fleet --config-for: " + config;
            return;
        }
        // Node names as the nodes call themselves, so X-Dfb-Node names the real node.
        for (size_t i = 0; i < nodes.size(); ++i) {
            config = std::regex_replace(config, std::regex("server node" + std::to_string(i + 1) + " "), "server " + nodes[i]->name + " ");
        }
        std::ofstream(dir / "haproxy.cfg") << config;
        process = std::make_unique<Process>(std::vector<std::string>{"/usr/sbin/haproxy", "-db", "-f", (dir / "haproxy.cfg").string()});
        for (int i = 0; i < 100 && tryHttp(port, "GET", "/healthz", "").status != 200; ++i) std::this_thread::sleep_for(100ms);
    }
    std::string port, error;
    std::unique_ptr<Process> process;
};

// Point 4: failover without loss, through a real HAProxy. Three nodes, six sessions: the sessions
// spread over the nodes; two clients edit one session over WebSockets through the router; the
// node owning it is SIGKILLed in the middle; both clients reconnect through the router within 10 s
// to the session on another node, where every edit either had acknowledged is in the rig and the
// history, and no edit was acknowledged twice.
TEST(Fleet, FailoverThroughHAProxyKeepsEveryAcknowledgedEdit) {
    ASSERT_TRUE(fs::exists("/usr/sbin/haproxy")) << "Debian's haproxy (scripts/setup installs it)";
    TempDir dir("failover");
    addShots(dir.path, 6);
    std::vector<std::unique_ptr<Node>> nodes;
    for (int i = 1; i <= 3; ++i) {
        nodes.push_back(std::make_unique<Node>(dir.path, "node" + std::to_string(i)));
        ASSERT_FALSE(nodes.back()->port.empty()) << nodes.back()->process->output();
    }
    Router router(dir.path, {nodes[0].get(), nodes[1].get(), nodes[2].get()});
    ASSERT_TRUE(router.error.empty()) << router.error;
    ASSERT_EQ(tryHttp(router.port, "GET", "/healthz", "").status, 200) << router.process->output();
    auto tokens = nodes[0]->tokens;

    // Every session through the router: each lands on one node, and they spread.
    std::map<std::string, std::string> owner;
    std::set<std::string> used;
    for (int i = 1; i <= 6; ++i) {
        const std::string id = "s" + std::to_string(i);
        const HttpReply r = tryHttp(router.port, "GET", "/v1/sessions/" + id + "/rig", tokens[id].editor);
        ASSERT_EQ(r.status, 200) << id << ": " << r.body;
        owner[id] = header(r, "X-Dfb-Node");
        used.insert(owner[id]);
        // Every request of a session goes to the same node.
        EXPECT_EQ(header(tryHttp(router.port, "GET", "/v1/sessions/" + id, tokens[id].viewer), "X-Dfb-Node"), owner[id]);
    }
    EXPECT_GE(used.size(), 2u) << "six sessions on at least two of three nodes";

    const std::string session = "s1";
    const std::string victim = owner[session];
    Node* victimNode = nullptr;
    for (auto& n : nodes) {
        if (n->name == victim) victimNode = n.get();
    }
    ASSERT_NE(victimNode, nullptr) << victim;

    struct ClientLog {
        std::vector<std::pair<uint64_t, double>> acked; // (version, value)
        std::optional<double> unacked;                  // sent when the connection broke
        double reconnectSeconds = -1;
        std::string error;
    };
    std::atomic<bool> killed{false};
    std::chrono::steady_clock::time_point killedAt;
    std::mutex mutex;
    auto client = [&](const std::string& path, double base, ClientLog& log) {
        std::unique_ptr<dfb::test::WsClient> ws;
        auto connect = [&]() -> bool {
            try {
                ws = std::make_unique<dfb::test::WsClient>(router.port, session, tokens[session].editor);
                return ws->nextText()["type"] == "welcome";
            } catch (const std::exception&) {
                ws.reset();
                return false;
            }
        };
        if (!connect()) {
            log.error = "first connect failed";
            return;
        }
        int i = 0, afterKill = 0;
        uint64_t seq = 0;
        const auto end = std::chrono::steady_clock::now() + 60s;
        while (afterKill < 15 && std::chrono::steady_clock::now() < end) {
            const double value = base + (++i);
            try {
                ws->send(json{{"type", "edit"}, {"seq", ++seq}, {"changes", {{{"path", path}, {"value", value}}}}});
                log.unacked = value;
                for (;;) {
                    json m = ws->nextText({"presence", "change", "library", "annotations"});
                    if (m.value("seq", uint64_t(0)) != seq) continue;
                    if (m.value("type", "") == "ack") {
                        log.acked.emplace_back(m["rigVersion"].get<uint64_t>(), value);
                        log.unacked.reset();
                        if (killed) ++afterKill;
                    } else if (m.value("code", "") != "moved") {
                        log.error = "refused: " + m.dump();
                        return;
                    }
                    break;
                }
                std::this_thread::sleep_for(20ms);
            } catch (const std::exception&) {
                // The node went away: reconnect through the router, with backoff, and go on
                // (the edit that got no ack is not sent again: it may or may not be in).
                const auto from = std::chrono::steady_clock::now();
                auto delay = 100ms;
                while (!connect() && std::chrono::steady_clock::now() - from < 30s) {
                    std::this_thread::sleep_for(delay);
                    delay = std::min(delay * 2, std::chrono::milliseconds(1000));
                }
                if (!ws) {
                    log.error = "no reconnect within 30 s";
                    return;
                }
                std::lock_guard lock(mutex);
                log.reconnectSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - (killed ? killedAt : from)).count();
            }
        }
    };
    ClientLog logA, logB;
    std::thread ta(client, "key.intensity", 1000.0, std::ref(logA)), tb(client, "fill.intensity", 2000.0, std::ref(logB));
    // dfb-client follows the session too: `watch` reconnects, `set` retries while it moves.
    const std::string link = "http://127.0.0.1:" + router.port + "/?session=" + session + "&token=" + tokens[session].editor;
    Process watch({DFB_CLIENT_EXE, "--server", link, "watch", "--duration", "12"});
    // Both clients edit for a while, then the owner dies in the middle of their stream.
    for (int i = 0; i < 100 && (logA.acked.size() < 10 || logB.acked.size() < 10); ++i) std::this_thread::sleep_for(100ms);
    {
        std::lock_guard lock(mutex);
        killedAt = std::chrono::steady_clock::now();
        victimNode->process->kill(SIGKILL);
        killed = true;
    }
    const auto [setRc, setOut] = dfb::test::run({DFB_CLIENT_EXE, "--server", link, "set", "key.coneAngle=33"}, 60s);
    EXPECT_EQ(setRc, 0) << "dfb-client set through the router while the session moves: " << setOut << "\nrouter:\n"
                        << router.process->output();
    ta.join();
    tb.join();
    EXPECT_EQ(watch.wait(30s), 0) << watch.output() << "\nrouter:\n" << router.process->output();
    EXPECT_NE(watch.output().find("reconnected to session " + session), std::string::npos) << watch.output();
    for (const ClientLog* log : {&logA, &logB}) {
        std::printf("fleet: %zu edits acknowledged, reconnected %.2f s after the kill\n", log->acked.size(), log->reconnectSeconds);
        EXPECT_TRUE(log->error.empty()) << log->error;
        EXPECT_GE(log->reconnectSeconds, 0) << "the client noticed the node's death";
        EXPECT_LT(log->reconnectSeconds, 10) << "reconnected through the router within 10 s";
    }
    ASSERT_GE(logA.acked.size(), 25u);
    ASSERT_GE(logB.acked.size(), 25u);

    // The session is open on another node, with every acknowledged edit.
    const HttpReply info = tryHttp(router.port, "GET", "/v1/sessions/" + session, tokens[session].editor);
    ASSERT_EQ(info.status, 200) << info.body;
    EXPECT_NE(header(info, "X-Dfb-Node"), victim);
    const json history = tryHttp(router.port, "GET", "/v1/sessions/" + session + "/history", tokens[session].editor).json();
    const json rig = tryHttp(router.port, "GET", "/v1/sessions/" + session + "/rig", tokens[session].editor).json();
    std::set<uint64_t> versions;
    for (const auto& [path, log, light] : {std::tuple{"key.intensity", &logA, "key"}, std::tuple{"fill.intensity", &logB, "fill"}}) {
        const auto values = historyValues(history, path);
        for (const auto& [version, value] : log->acked) {
            EXPECT_TRUE(versions.insert(version).second) << "version " << version << " acknowledged twice";
            ASSERT_TRUE(values.count(version)) << path << ": acknowledged version " << version << " is missing";
            EXPECT_DOUBLE_EQ(values.at(version), value);
        }
        // Each value at most once (no edit applied twice), and only acknowledged ones or the one in
        // flight at the kill.
        std::set<double> seen;
        for (const auto& [version, value] : values) EXPECT_TRUE(seen.insert(value).second) << path << " " << value << " applied twice";
        EXPECT_LE(values.size(), log->acked.size() + 1);
        // The rig holds the client's last acknowledged value (its edits after it were acknowledged too).
        EXPECT_DOUBLE_EQ(intensityOf(rig, light), log->acked.back().second) << path;
    }
    for (const auto& l : rig["lights"]) {
        if (l.value("name", "") == "key") {
            EXPECT_DOUBLE_EQ(l["coneAngle"].get<double>(), 33.0);
        }
    }
}

} // namespace
