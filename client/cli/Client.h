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
#include <thread>

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
    /// --retry: seconds a request, a WebSocket connect and `watch` keep retrying a session that
    /// is moving to another node of a fleet (docs/deployment.md "Failover"); 0: never.
    double retryS = 20.0;
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
    /// exits 3. A session moving between nodes is waited for (retryable()).
    client::HttpResponse request(const std::string& method, const std::string& target, const std::string& body = "",
                                 const std::string& ifMatch = "") {
        Backoff backoff(mOpt.retryS);
        auto r = client::httpRequest(mUrl, method, target, mToken, body, ifMatch, timeout(), mOpt.name);
        while (r && retryable(*r, method) && backoff.wait()) {
            r = client::httpRequest(mUrl, method, target, mToken, body, ifMatch, timeout(), mOpt.name);
        }
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

    /// A WebSocket on the session, greeted: returns the welcome message. A session moving
    /// between nodes (Moved, or the router's 502/503) is waited for up to --retry.
    std::unique_ptr<client::Connection> connect(json* welcome) {
        Backoff backoff(mOpt.retryS);
        auto c = client::Connection::open(mUrl, base() + "/ws?token=" + mToken, timeout());
        while (!c && movingRefusal(c.error()) && backoff.wait()) c = client::Connection::open(mUrl, base() + "/ws?token=" + mToken, timeout());
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

    const Options& options() const { return mOpt; }

    /// Waits between retries: 100 ms doubling to 2 s, until `budgetS` seconds have passed.
    class Backoff {
    public:
        explicit Backoff(double budgetS)
            : mDeadline(std::chrono::steady_clock::now() + std::chrono::milliseconds(long(budgetS * 1000))) {}
        /// Sleeps and returns true, or returns false when the budget would be exceeded.
        bool wait() {
            if (std::chrono::steady_clock::now() + mDelay > mDeadline) return false;
            std::this_thread::sleep_for(mDelay);
            mDelay = std::min(mDelay * 2, std::chrono::milliseconds(2000));
            return true;
        }

    private:
        std::chrono::steady_clock::time_point mDeadline;
        std::chrono::milliseconds mDelay{100};
    };

    /// What a fleet answers while a session moves between nodes (docs/deployment.md "Failover"):
    /// 503 `moved` from a node (nothing was done), or the router's own 503 (no node up) or, for a
    /// GET, 502/504 (the node died with the request). A POST that got 502 may have been applied:
    /// it is not sent again.
    static bool retryable(const client::HttpResponse& r, const std::string& method) {
        if (r.status == 503) {
            auto parsed = protocol::parseJson(r.body, 1 << 20, "the server's answer");
            // A node's own 503s are JSON: only `moved` passes by waiting (not `unavailable`, a
            // damaged journal, nor `limit_exceeded`, too many connections).
            return !parsed || !parsed.value().is_object() || parsed.value().value("code", "") == "moved";
        }
        return (r.status == 502 || r.status == 504) && (method == "GET" || method == "HEAD");
    }
    /// The same for a WebSocket upgrade refused (Connection::open's error).
    static bool movingRefusal(const Error& e) {
        if (e.code == ErrorCode::Moved) return true;
        if (e.code == ErrorCode::Unavailable) return false;
        for (const char* status : {"(HTTP 502)", "(HTTP 503)", "(HTTP 504)"}) {
            if (e.message.find(status) != std::string::npos) return true;
        }
        return false;
    }

private:
    Options mOpt;
    client::Url mUrl;
    std::string mToken, mSession;
};


} // namespace dfb::cli
