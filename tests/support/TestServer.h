#pragma once
// Test support: a dfb-server on a free loopback port (started with --port 0), with the tokens it
// printed for each session. Stopped when the object goes.

#include "support/NetClient.h"
#include "support/Process.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <map>
#include <memory>
#include <regex>
#include <string>
#include <vector>

namespace dfb::test {

struct Tokens {
    std::string editor, viewer;
};

/// The tokens in a dfb-server's output ("session ID editor|viewer: URL...token=T"), by session.
inline std::map<std::string, Tokens> printedTokens(const std::string& out) {
    std::map<std::string, Tokens> tokens;
    const std::regex line(R"(session (\S+) (editor|viewer): https?://\S+token=([\w.~-]+))");
    for (auto it = std::sregex_iterator(out.begin(), out.end(), line); it != std::sregex_iterator(); ++it) {
        auto& t = tokens[(*it)[1]];
        ((*it)[2] == "editor" ? t.editor : t.viewer) = (*it)[3];
    }
    return tokens;
}

// A dfb-server on a free loopback port; knows the tokens it printed.
struct Server {
    explicit Server(std::vector<std::string> args) {
        args.insert(args.begin(), DFB_SERVER_EXE);
        args.insert(args.end(), {"--port", "0"});
        // The figures of these tests (lit areas, shadow shares, light groups) are of the plain key
        // and fill on the tabletop's bounds; the default three-point rig is tested where it is
        // asked for ("--default-rig three-point") and in default_rig_test.
        if (std::find(args.begin(), args.end(), "--default-rig") == args.end()) args.insert(args.end(), {"--default-rig", "key-fill"});
        process = std::make_unique<Process>(args);
        auto m = process->waitForLine(std::regex(R"(listening on https?://127\.0\.0\.1:(\d+)/)"), std::chrono::seconds(60));
        if (!m) return;
        port = (*m)[1];
        tokens = printedTokens(process->output());
    }
    bool up() const { return !port.empty(); }
    /// The editor link the server printed for `session` (what a user gives dfb-client).
    std::string editorLink(const std::string& session) {
        return "http://127.0.0.1:" + port + "/?session=" + session + "&token=" + tokens[session].editor;
    }
    /// The only session's id (for a server started on one shot).
    std::string onlySession() const { return tokens.size() == 1 ? tokens.begin()->first : ""; }
    HttpReply get(const std::string& target, const std::string& token) { return http(port, "GET", target, token); }
    nlohmann::json rig(const std::string& session) { return get("/v1/sessions/" + session + "/rig", tokens[session].editor).json(); }

    std::unique_ptr<Process> process;
    std::string port;
    std::map<std::string, Tokens> tokens;
};

} // namespace dfb::test
