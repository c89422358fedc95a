#pragma once
// dfb-client's connection to one server: options, exit codes (docs/operations.md "dfb-client"),
// HTTP requests and a greeted WebSocket on the session. Shared by the subcommands and bench.

#include "Connection.h"

#include <dfb/core/CommandLine.h>

#include <dfb/protocol/Json.h>
#include <dfb/protocol/Messages.h>

#include <nlohmann/json.hpp>

#include <pwd.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>

namespace dfb::cli {

using json = nlohmann::json;

constexpr int EXIT_OK = 0, EXIT_USAGE = dfb::EXIT_COMMAND_LINE, EXIT_UNREACHABLE = 2, EXIT_REFUSED = 3, EXIT_BROKEN = 4, EXIT_FILE = 5;

/// The user's login name (the default --name: the author of edits in the history and presence).
inline std::string loginName() {
    if (const passwd* pw = ::getpwuid(::geteuid()); pw && pw->pw_name && *pw->pw_name) return pw->pw_name;
    if (const char* u = std::getenv("USER"); u && *u) return u;
    return "dfb-client";
}

/// A server's refusal as the client prints it: "error CODE: message" (docs/operations.md).
inline std::string serverErrorText(const json& j, const std::string& fallback) {
    if (j.is_object() && j["code"].is_string() && j["message"].is_string()) {
        return "error " + j["code"].get<std::string>() + ": " + j["message"].get<std::string>();
    }
    return "error: " + fallback;
}

struct Options {
    std::string server = "http://127.0.0.1:8080";
    std::string session;
    std::string token;
    std::string name = loginName();
    double timeoutS = 30.0;
    std::string caCert;
};

/// Thrown inside a subcommand to leave with an exit code (caught in main only).
struct Exit {
    int code;
};

[[noreturn]] inline void die(int code, const std::string& message) {
    std::cerr << "dfb-client: " << message << "\n";
    throw Exit{code};
}

class Client {
public:
    explicit Client(const Options& o) : mOpt(o) {
        auto u = client::parseUrl(o.server);
        if (!u) die(EXIT_USAGE, u.error().message);
        mUrl = u.value();
        mUrl.caFile = o.caCert;
        mToken = !o.token.empty() ? o.token : mUrl.token;
        mSession = !o.session.empty() ? o.session : mUrl.session;
    }
    std::chrono::milliseconds timeout() const { return std::chrono::milliseconds(long(mOpt.timeoutS * 1000)); }

    /// One request; a refusal (non-2xx) prints "error CODE: message" (the server's words) and
    /// exits 3.
    client::HttpResponse request(const std::string& method, const std::string& target, const std::string& body = "",
                                 const std::string& ifMatch = "") {
        auto r = client::httpRequest(mUrl, method, target, mToken, body, ifMatch, timeout(), mOpt.name);
        if (!r) fail(r.error());
        if (r->status / 100 != 2) {
            auto parsed = protocol::parseJson(r->body, 1 << 20, "the server's answer");
            const std::string where = " (HTTP " + std::to_string(r->status) + ", " + method + " " + target.substr(0, target.find('?')) + ")";
            die(EXIT_REFUSED, serverErrorText(parsed ? parsed.value() : json(), r->body) + where);
        }
        return r.value();
    }

    [[noreturn]] void fail(const Error& e) {
        if (e.code == ErrorCode::Network) {
            const bool unreachable = e.message.rfind("connecting", 0) == 0 || e.message.rfind("resolving", 0) == 0;
            die(unreachable ? EXIT_UNREACHABLE : EXIT_BROKEN, e.message);
        }
        die(EXIT_REFUSED, std::string("error ") + dfb::toString(e.code) + ": " + e.message);
    }

    /// The session to talk to: --session, the URL's, or the only one the token opens.
    const std::string& session() {
        if (!mSession.empty()) return mSession;
        auto r = request("GET", "/v1/sessions");
        auto parsed = protocol::parseJson(r.body, 64u << 20, "GET /v1/sessions");
        const json j = parsed ? std::move(parsed.value()) : json();
        if (!j.is_object() || !j["sessions"].is_array()) die(EXIT_BROKEN, "GET /v1/sessions: unreadable answer");
        if (j["sessions"].size() != 1) {
            std::string ids;
            for (const auto& s : j["sessions"]) ids += " " + s.value("id", "");
            die(EXIT_USAGE, "the token opens several sessions; pick one with --session:" + ids);
        }
        mSession = j["sessions"][0].value("id", "");
        return mSession;
    }
    std::string base() { return "/v1/sessions/" + session(); }

    /// A WebSocket on the session, greeted: returns the welcome message.
    std::unique_ptr<client::Connection> connect(json* welcome) {
        auto c = client::Connection::open(mUrl, base() + "/ws?token=" + mToken, timeout());
        if (!c) fail(c.error());
        if (auto s = c.value()->sendText(protocol::encode(protocol::HelloMessage{protocol::PROTOCOL_VERSION, mOpt.name})); !s) fail(s.error());
        for (;;) {
            auto m = c.value()->receive();
            if (!m) fail(m.error());
            if (auto* t = std::get_if<client::TextMessage>(&m.value())) {
                if (t->json.value("type", "") == "welcome") {
                    *welcome = t->json;
                    return std::move(c.value());
                }
                if (t->json.value("type", "") == "error") die(EXIT_REFUSED, serverErrorText(t->json, t->json.dump()));
            }
        }
    }

private:
    Options mOpt;
    client::Url mUrl;
    std::string mToken, mSession;
};


} // namespace dfb::cli
