#include "net/HttpSession.h"

#include "net/WebSocketSession.h"

#include <dfb/protocol/Codec.h>
#include <dfb/protocol/Messages.h>
#include <dfb/protocol/Schema.h>
#include <dfb/server/Drag.h>
#include <dfb/server/GltfExport.h>

#include <cctype>
#include <cstdlib>
#include <string_view>

namespace dfb::web {
// The browser page's files by name, embedded at build time (cmake/EmbedFiles.cmake); empty for
// any other name.
std::string_view asset(std::string_view name);
}

namespace dfb::net {
namespace {

using json = nlohmann::json;

// Requests larger than this are refused: a rig or an edit is far smaller.
constexpr size_t MAX_BODY_BYTES = 1 << 20;
// The request line and headers together (Beast's default is 8 KiB): a browser's are ~1 KB.
constexpr size_t MAX_HEADER_BYTES = 16 << 10;
// The request target: our URLs carry a session, a token and a few view settings.
constexpr size_t MAX_URL_BYTES = 8 << 10;

http::response<http::string_body> makeResponse(unsigned version, bool keepAlive, http::status status, std::string_view contentType,
                                               std::string body) {
    http::response<http::string_body> res{status, version};
    res.set(http::field::server, "dfb-server");
    res.set(http::field::content_type, std::string(contentType));
    res.set(http::field::cache_control, "no-store");
    res.keep_alive(keepAlive);
    res.body() = std::move(body);
    res.prepare_payload();
    return res;
}

http::response<http::string_body> makeResponse(const http::request<http::string_body>& req, http::status status,
                                               std::string_view contentType, std::string body) {
    return makeResponse(req.version(), req.keep_alive(), status, contentType, std::move(body));
}

// The HTTP status of a refusal (docs/protocol.md "Errors").
http::status statusFor(ErrorCode code) {
    switch (code) {
    case ErrorCode::Unauthorized: return http::status::unauthorized;
    case ErrorCode::Forbidden: return http::status::forbidden;
    case ErrorCode::Conflict: return http::status::precondition_failed;
    case ErrorCode::MissingData: return http::status::not_found;
    case ErrorCode::GpuError:
    case ErrorCode::IoError: return http::status::internal_server_error;
    case ErrorCode::Unavailable:
    case ErrorCode::Moved: return http::status::service_unavailable;
    default: return http::status::bad_request;
    }
}

http::response<http::string_body> errorResponse(unsigned version, bool keepAlive, const Error& e,
                                                std::optional<http::status> status = std::nullopt) {
    auto res = makeResponse(version, keepAlive, status.value_or(statusFor(e.code)), "application/json",
                            protocol::encodeError(e.code, e.message, std::nullopt));
    if (e.code == ErrorCode::Unauthorized) res.set(http::field::www_authenticate, "Bearer realm=\"dfb\"");
    // A moved session is open on another node, which hands it over within a second or two
    // (docs/deployment.md "Leases"); a session that failed to open needs its operator.
    if (res.result() == http::status::service_unavailable) res.set(http::field::retry_after, e.code == ErrorCode::Moved ? "1" : "5");
    return res;
}

http::response<http::string_body> errorResponse(const http::request<http::string_body>& req, ErrorCode code, const std::string& message,
                                                std::optional<http::status> status = std::nullopt) {
    return errorResponse(req.version(), req.keep_alive(), makeError(code, message), status);
}

std::optional<std::string> queryParam(std::string_view query, std::string_view name) {
    while (!query.empty()) {
        const size_t amp = query.find('&');
        const std::string_view item = query.substr(0, amp);
        query = amp == std::string_view::npos ? std::string_view() : query.substr(amp + 1);
        const size_t eq = item.find('=');
        if (item.substr(0, eq) == name) return protocol::percentDecode(eq == std::string_view::npos ? "" : item.substr(eq + 1));
    }
    return std::nullopt;
}

// The token of a request: "Authorization: Bearer T" (scripts) or "?token=T" (browsers cannot set
// headers on a WebSocket).
std::string tokenOf(const http::request<http::string_body>& req, std::string_view query) {
    const auto auth = req[http::field::authorization];
    if (auth.size() > 7 && (auth.substr(0, 7) == "Bearer " || auth.substr(0, 7) == "bearer ")) return std::string(auth.substr(7));
    return queryParam(query, "token").value_or("");
}

// If-Match: "V" or V (the rig version), or * (any). Nothing when absent; Protocol when unreadable.
Result<std::optional<uint64_t>> ifMatch(const http::request<http::string_body>& req) {
    auto h = std::string(req[http::field::if_match]);
    if (h.empty() || h == "*") return std::optional<uint64_t>{};
    if (h.size() >= 2 && h.front() == '"' && h.back() == '"') h = h.substr(1, h.size() - 2);
    if (h.empty() || h.size() > 19 || h.find_first_not_of("0123456789") != std::string::npos) {
        return makeError(ErrorCode::Protocol, "If-Match: expected the rig version as an ETag, e.g. \"12\"");
    }
    return std::optional<uint64_t>{std::stoull(h)};
}

// An editor's request body (PUT rig, POST edits, POST drag): the If-Match version and the JSON
// body, bounded by MAX_BODY_BYTES; `objectShape` (non-null) requires a JSON object and names its
// shape in the error. `what` names the request ("POST edits").
struct EditorBody {
    std::optional<uint64_t> expected;
    json body;
};
Result<EditorBody> editorBody(const http::request<http::string_body>& req, const std::string& what,
                              const char* objectShape = nullptr) {
    auto expected = ifMatch(req);
    if (!expected) return expected.error();
    auto body = protocol::parseJson(req.body(), MAX_BODY_BYTES, what + ": the body");
    if (!body) return body.error();
    if (objectShape && !body->is_object()) {
        return makeError(ErrorCode::Protocol, what + ": the body must be a JSON object " + objectShape);
    }
    return EditorBody{expected.value(), std::move(body.value())};
}

std::string etag(uint64_t version) { return "\"" + std::to_string(version) + "\""; }

// The browser page's file that `path` names, or an empty view: "/" is index.html, "/NAME" the
// file NAME of DFB_WEB_FILES (server/CMakeLists.txt), embedded at build time. The lookup compares
// whole names, so nothing else is reachable: no other file of client/web, no "..", no encoding.
std::string_view webFile(std::string_view path) {
    if (path == "/") return web::asset("index.html");
    if (path.size() < 2 || path[0] != '/') return {};
    return web::asset(path.substr(1));
}

// Its type, by extension: DFB_WEB_FILES admits only these three. Module scripts must come as
// JavaScript (browsers refuse a module of another type), so the type is never guessed.
std::string_view webContentType(std::string_view path) {
    auto endsWith = [&](std::string_view ext) {
        return path.size() >= ext.size() && path.substr(path.size() - ext.size()) == ext;
    };
    if (endsWith(".js")) return "text/javascript; charset=utf-8";
    if (endsWith(".css")) return "text/css; charset=utf-8";
    return "text/html; charset=utf-8";
}

} // namespace

HttpSession::HttpSession(Stream&& stream, std::shared_ptr<SharedState> state, std::shared_ptr<void> slot)
    : mStream(std::move(stream)), mState(std::move(state)), mSlot(std::move(slot)) {}

void HttpSession::run() {
    asio::dispatch(mStream.get_executor(), [self = shared_from_this()] {
        if (!self->mStream.tls()) return self->doRead();
        // A client that connects and never finishes the handshake holds a slot for 30 s at most.
        beast::get_lowest_layer(self->mStream).expires_after(std::chrono::seconds(30));
        self->mStream.tlsStream().async_handshake(asio::ssl::stream_base::server,
                                                  beast::bind_front_handler(&HttpSession::onHandshake, self));
    });
}

void HttpSession::onHandshake(error_code ec) {
    if (ec) return fail(ec, "tls handshake");
    doRead();
}

void HttpSession::shutdown() {
    error_code ec;
    if (!mStream.tls()) {
        mStream.next_layer().socket().shutdown(tcp::socket::shutdown_send, ec);
        return;
    }
    beast::get_lowest_layer(mStream).expires_after(std::chrono::seconds(5));
    mStream.tlsStream().async_shutdown([self = shared_from_this()](error_code) {
        error_code ignored;
        self->mStream.next_layer().socket().shutdown(tcp::socket::shutdown_send, ignored);
    });
}

void HttpSession::doRead() {
    mParser.emplace();
    mParser->body_limit(MAX_BODY_BYTES);
    mParser->header_limit(MAX_HEADER_BYTES);
    beast::get_lowest_layer(mStream).expires_after(std::chrono::seconds(60));
    http::async_read(mStream, mBuffer, *mParser, beast::bind_front_handler(&HttpSession::onRead, shared_from_this()));
}

void HttpSession::onRead(error_code ec, size_t) {
    if (ec == http::error::end_of_stream) return shutdown();
    if (ec == http::error::body_limit) {
        Request req; // the rest of the body is unread: answer, then close
        req.keep_alive(false);
        return send(errorResponse(req, ErrorCode::Protocol, "request body larger than 1 MiB", http::status::payload_too_large));
    }
    if (ec == http::error::header_limit) {
        // Beast counts the request line in the header limit and parses it first: a request
        // whose target was not read (or is over the URL limit) has a long URL, else long headers.
        const auto target = mParser->get().target();
        const bool longUrl = target.empty() || target.size() > MAX_URL_BYTES;
        Request req;
        req.keep_alive(false);
        if (longUrl) {
            return send(errorResponse(req, ErrorCode::LimitExceeded, "the request's URL is over the limit of " + std::to_string(MAX_URL_BYTES) + " bytes",
                                      http::status::uri_too_long));
        }
        return send(errorResponse(req, ErrorCode::LimitExceeded,
                                  "the request's headers are over the limit of " + std::to_string(MAX_HEADER_BYTES) + " bytes",
                                  http::status::request_header_fields_too_large));
    }
    if (ec) return fail(ec, "http read");
    if (mParser->get().target().size() > MAX_URL_BYTES) {
        Request req;
        req.keep_alive(false);
        return send(errorResponse(req, ErrorCode::LimitExceeded, "the request's URL is over the limit of " + std::to_string(MAX_URL_BYTES) + " bytes",
                                  http::status::uri_too_long));
    }
    if (!mSlot) {
        Request req;
        req.keep_alive(false);
        mState->metrics().connectionRefused();
        return send(errorResponse(req, ErrorCode::LimitExceeded,
                                  "too many connections from this address: the limit is " + std::to_string(mState->limits().maxConnectionsPerAddress) +
                                      " (--max-connections-per-address)",
                                  http::status::service_unavailable));
    }
    if (websocket::is_upgrade(mParser->get())) {
        auto req = mParser->release();
        const std::string target(req.target());
        const size_t q = target.find('?');
        const std::string path = target.substr(0, q), query = q == std::string::npos ? "" : target.substr(q + 1);
        const std::string prefix = "/v1/sessions/";
        if (path.rfind(prefix, 0) != 0 || path.size() < prefix.size() + 4 || path.substr(path.size() - 3) != "/ws") {
            return send(errorResponse(req, ErrorCode::MissingData, "the WebSocket endpoint is /v1/sessions/ID/ws"));
        }
        const std::string id = path.substr(prefix.size(), path.size() - prefix.size() - 3);
        const std::string token = tokenOf(req, query);
        if (token.empty()) return send(errorResponse(req, ErrorCode::Unauthorized, "no token: add ?token=... or an Authorization: Bearer header"));
        // Opened first when it is not open on this node (the read stays paused meanwhile).
        auto request = std::make_shared<Request>(std::move(req));
        mState->acquire(id, token, [self = shared_from_this(), request](auto acquired) {
            if (!acquired) return self->sendRefusal(*request, acquired.error());
            beast::get_lowest_layer(self->mStream).expires_never();
            auto [hub, role] = acquired.value();
            std::make_shared<WebSocketSession>(std::move(self->mStream), self->mState, hub, role, std::move(self->mSlot))
                ->run(std::move(*request));
        });
        return;
    }
    handle(mParser->release());
}

void HttpSession::handle(Request&& req) {
    const std::string target(req.target());
    const size_t q = target.find('?');
    const std::string path = target.substr(0, q), query = q == std::string::npos ? "" : target.substr(q + 1);
    const bool get = req.method() == http::verb::get || req.method() == http::verb::head;
    const std::string_view page = webFile(path);
    if (!page.empty() || path == "/healthz" || path == "/readyz" || path == "/metrics" || path == "/favicon.ico" || path == "/v1/sessions" ||
        path == "/v1/schema") {
        if (!get) return send(errorResponse(req, ErrorCode::Protocol, "method not allowed on " + path, http::status::method_not_allowed));
    }
    // The page holds no data of any session: it asks for a token (from its own URL) to connect.
    if (!page.empty()) {
        const std::string_view type = webContentType(path == "/" ? "/index.html" : path);
        auto res = makeResponse(req, http::status::ok, type, std::string(page));
        // The declared type is the only one a browser may take it for (no sniffing).
        res.set("X-Content-Type-Options", "nosniff");
        return send(std::move(res));
    }
    if (path == "/healthz") return send(makeResponse(req, http::status::ok, "text/plain", "ok\n"));
    // Readiness (docs/deployment.md): false from SIGTERM on, so the router sends nothing new here.
    if (path == "/readyz") {
        return send(mState->draining() ? makeResponse(req, http::status::service_unavailable, "text/plain", "draining\n")
                                       : makeResponse(req, http::status::ok, "text/plain", "ready\n"));
    }
    if (path == "/metrics") {
        return send(makeResponse(req, http::status::ok, "text/plain; version=0.0.4", mState->metrics().text(mState->limits().metricsSessionNames)));
    }
    if (path == "/favicon.ico") return send(makeResponse(req, http::status::no_content, "image/x-icon", ""));
    // The rig schema: the same for every session and free of any session's data.
    if (path == "/v1/schema") {
        static const std::string schema = protocol::schemaJson().dump();
        return send(makeResponse(req, http::status::ok, "application/json", schema));
    }

    const std::string token = tokenOf(req, query);
    if (path == "/v1/sessions") {
        if (token.empty()) return send(errorResponse(req, ErrorCode::Unauthorized, "no token: send Authorization: Bearer TOKEN"));
        const json list = mState->sessionList(token);
        if (list.empty()) return send(errorResponse(req, ErrorCode::Unauthorized, "the token opens no session"));
        return send(makeResponse(req, http::status::ok, "application/json", protocol::dump(json{{"sessions", list}}, 2)));
    }
    const std::string prefix = "/v1/sessions/";
    if (path.rfind(prefix, 0) == 0) {
        const std::string rest = path.substr(prefix.size());
        const size_t slash = rest.find('/');
        const std::string id = rest.substr(0, slash), resource = slash == std::string::npos ? "" : rest.substr(slash + 1);
        if (token.empty()) return send(errorResponse(req, ErrorCode::Unauthorized, "no token: send Authorization: Bearer TOKEN"));
        auto request = std::make_shared<Request>(std::move(req));
        mState->acquire(id, token, [self = shared_from_this(), request, resource, query](auto acquired) {
            if (!acquired) return self->sendRefusal(*request, acquired.error());
            auto [hub, role] = acquired.value();
            self->handleSession(*request, hub, role, resource, query);
        });
        return;
    }
    send(errorResponse(req, ErrorCode::MissingData, "no such resource: " + path));
}

void HttpSession::handleSession(const Request& req, const std::shared_ptr<SessionHub>& hub, protocol::Role role,
                                const std::string& resource, const std::string& query) {
    Session& session = hub->session();
    const bool get = req.method() == http::verb::get || req.method() == http::verb::head;
    const bool post = req.method() == http::verb::post, put = req.method() == http::verb::put;
    auto notAllowed = [&](const char* allowed) {
        auto res = errorResponse(req, ErrorCode::Protocol, std::string(req.method_string()) + " is not allowed on " + std::string(req.target()) +
                                                                " (allowed: " + allowed + ")",
                                 http::status::method_not_allowed);
        res.set(http::field::allow, allowed);
        return send(std::move(res));
    };
    auto refuse = [&](const Error& e, std::optional<http::status> status = std::nullopt) {
        if (e.code != ErrorCode::Unauthorized) hub->metrics().editRefused(hub->id());
        send(errorResponse(req.version(), req.keep_alive(), makeError(e.code, mState->redact(e.message)), status));
    };
    // Accepted changes: every WebSocket client hears of them, as of any other change.
    auto accepted = [&](const ChangeOutcome& out, json body) {
        hub->published(out, nullptr);
        body["rigVersion"] = out.info.rigVersion;
        auto res = makeResponse(req, http::status::ok, "application/json", protocol::dump(body, 2));
        res.set(http::field::etag, etag(out.info.rigVersion));
        send(std::move(res));
    };
    // The author of HTTP changes: the X-Dfb-Name header (dfb-client sends --name), else "http".
    std::string byName = protocol::clientName(std::string(req["X-Dfb-Name"]));
    const Author author{0, byName.empty() ? std::string("http") : byName};
    auto editorOnly = [&]() {
        if (role == protocol::Role::Editor) return true;
        refuse(makeError(ErrorCode::Forbidden, "a viewer token cannot change session '" + hub->id() + "'"));
        return false;
    };

    if (resource.empty()) {
        if (!get) return notAllowed("GET, HEAD");
        json info{{"id", hub->id()},
                  {"role", protocol::toString(role)},
                  {"session", session.description()},
                  {"rigVersion", session.rigVersion()},
                  {"persistent", session.persistent()},
                  {"history", {{"undo", session.undoDepth()}, {"redo", session.redoDepth()}}},
                  {"clients", json::array()}};
        for (const auto& c : hub->clients()) info["clients"].push_back(protocol::toJson(c));
        return send(makeResponse(req, http::status::ok, "application/json", protocol::dump(info, 2)));
    }
    if (resource == "rig") {
        if (get) {
            const Rig rig = session.rig();
            auto res = makeResponse(req, http::status::ok, "application/json", protocol::dump(protocol::toJson(rig), 2));
            res.set(http::field::etag, etag(rig.version));
            return send(std::move(res));
        }
        if (!put) return notAllowed("GET, HEAD, PUT");
        if (!editorOnly()) return;
        auto in = editorBody(req, "PUT rig");
        if (!in) return refuse(in.error());
        auto rig = protocol::rigFromJson(in->body);
        if (!rig) return refuse(rig.error(), http::status::bad_request);
        auto out = session.replace(rig.value(), author, in->expected);
        if (!out) return refuse(out.error());
        return accepted(out.value(), json::object());
    }
    if (resource == "edits") {
        if (!post) return notAllowed("POST");
        if (!editorOnly()) return;
        // The body is an edit message without "type" and "seq": parsed by the WebSocket's codec.
        auto in = editorBody(req, "POST edits", "{\"changes\": [...]}");
        if (!in) return refuse(in.error());
        const std::optional<uint64_t> expected = in->expected;
        json& body = in->body;
        body["type"] = "edit";
        body["seq"] = uint64_t(0);
        auto parsed = protocol::clientMessageFromJson(body);
        if (!parsed) return refuse(parsed.error());
        auto& edit = std::get<protocol::EditMessage>(parsed.value());
        if (expected && !edit.ifVersion) edit.ifVersion = expected;
        auto out = session.edit(edit.changes, author, edit.base, edit.ifVersion, false, edit.allowFold);
        if (!out) return refuse(out.error(), out.error().code == ErrorCode::MissingData ? std::optional(http::status::bad_request) : std::nullopt);
        json extra = json::object();
        if (!out->overwrote.empty()) extra["overwrote"] = out->overwrote;
        if (!out->limited.empty()) extra["limited"] = out->limited;
        return accepted(out.value(), extra);
    }
    if (resource == "undo" || resource == "redo") {
        if (!post) return notAllowed("POST");
        if (!editorOnly()) return;
        auto out = resource == "undo" ? session.undo(author) : session.redo(author);
        if (!out) return refuse(out.error(), out.error().code == ErrorCode::MissingData ? std::optional(http::status::conflict) : std::nullopt);
        return accepted(out.value(), json{{"kind", resource}});
    }
    if (resource.rfind("history/", 0) == 0) {
        // "Go to this version": POST history/V/restore replaces the rig with the one of version V
        // (Session::rigAtVersion) as one undoable edit, kind replace.
        const std::string rest = resource.substr(8);
        const size_t slash = rest.find('/');
        const std::string v = rest.substr(0, slash), action = slash == std::string::npos ? "" : rest.substr(slash + 1);
        if (action != "restore" || v.empty() || v.size() > 19 || v.find_first_not_of("0123456789") != std::string::npos) {
            return refuse(makeError(ErrorCode::MissingData, "no such resource: history/" + rest.substr(0, 64) +
                                                                " (expected history/VERSION/restore)"),
                          http::status::not_found);
        }
        if (!post) return notAllowed("POST");
        if (!editorOnly()) return;
        auto expected = ifMatch(req);
        if (!expected) return refuse(expected.error());
        const uint64_t version = std::stoull(v);
        auto rig = session.rigAtVersion(version);
        if (!rig) return refuse(rig.error(), http::status::not_found);
        auto out = session.replace(rig.value(), author, expected.value());
        if (!out) return refuse(out.error());
        return accepted(out.value(), json{{"restored", version}});
    }
    if (resource == "history") {
        if (!get) return notAllowed("GET, HEAD");
        uint64_t since = 0;
        if (auto s = queryParam(query, "since")) {
            if (s->empty() || s->size() > 19 || s->find_first_not_of("0123456789") != std::string::npos) {
                return refuse(makeError(ErrorCode::InvalidValue, "since: expected a rig version"));
            }
            since = std::stoull(*s);
        }
        return send(makeResponse(req, http::status::ok, "application/json",
                                 protocol::dump(json{{"rigVersion", session.rigVersion()}, {"entries", session.history(since)}}, 2)));
    }
    const unsigned version = req.version();
    const bool keepAlive = req.keep_alive();
    if (resource == "frame") {
        if (!get) return notAllowed("GET, HEAD");
        auto view = protocol::viewFromQuery(query);
        if (!view) return refuse(view.error());
        hub->render().requestEncoded(view.value(), [self = shared_from_this(), hub, version, keepAlive](Result<std::shared_ptr<const EncodedFrame>> f) {
            Response res;
            if (!f) {
                res = errorResponse(version, keepAlive, makeError(f.error().code, self->mState->redact(f.error().message)),
                                    f.error().code == ErrorCode::MissingData ? std::optional(http::status::bad_request) : std::nullopt);
            } else {
                const auto& frame = *f.value();
                res = makeResponse(version, keepAlive, http::status::ok, protocol::mimeType(frame.encoding),
                                   std::string(reinterpret_cast<const char*>(frame.image()), frame.imageSize()));
                res.set("X-Rig-Version", std::to_string(frame.rigVersion));
                res.set("X-Frame-Number", std::to_string(frame.frameNumber));
                hub->metrics().frameSent(hub->id(), frame.imageSize());
            }
            asio::post(self->mStream.get_executor(), [self, r = std::move(res)]() mutable { self->send(std::move(r)); });
        }, /*fullQuality=*/true);
        return;
    }
    if (resource == "library" || resource == "snapshots" || resource == "rigs" || resource.rfind("snapshots/", 0) == 0 ||
        resource.rfind("rigs/", 0) == 0) {
        // Snapshots and saved rigs (session/Library.h; docs/protocol.md "Snapshots and saved
        // rigs"): read by any role, changed by editors; every change is told to every client.
        Library& library = hub->library();
        const bool del = req.method() == http::verb::delete_;
        if (resource == "library") {
            if (!get) return notAllowed("GET, HEAD");
            return send(makeResponse(req, http::status::ok, "application/json", protocol::dump(library.list(), 2)));
        }
        const bool snapshots = resource.rfind("snapshots", 0) == 0;
        const std::string kind = snapshots ? "snapshots" : "rigs";
        // The name a POST to the list gives: {"name": "..."}.
        auto nameFromBody = [&](const std::string& what) -> Result<std::string> {
            auto in = editorBody(req, what, "{\"name\": \"...\"}");
            if (!in) return in.error();
            if (!in->body.contains("name") || !in->body["name"].is_string()) {
                return makeError(ErrorCode::Protocol, what + ": expected {\"name\": \"...\"}");
            }
            return in->body["name"].get<std::string>();
        };
        if (resource == kind) {
            if (get) return send(makeResponse(req, http::status::ok, "application/json", protocol::dump(library.list()[kind], 2)));
            if (!post) return notAllowed("GET, HEAD, POST");
            if (!editorOnly()) return;
            auto name = nameFromBody("POST " + kind);
            if (!name) return refuse(name.error(), http::status::bad_request);
            if (!snapshots) {
                auto out = library.saveRig(name.value(), session.rig(), author.name);
                if (!out) return refuse(out.error(), out.error().code == ErrorCode::InvalidValue ? std::optional(http::status::bad_request) : std::nullopt);
                hub->libraryChanged();
                return send(makeResponse(req, http::status::ok, "application/json", protocol::dump(out.value(), 2)));
            }
            if (!protocol::isValidName(name.value())) {
                return refuse(makeError(ErrorCode::InvalidValue, "snapshot name '" + name->substr(0, 64) + "': " + protocol::NAME_RULE),
                              http::status::bad_request);
            }
            if (library.snapshot(name.value()).ok()) {
                return refuse(makeError(ErrorCode::Conflict, "a snapshot named '" + name.value() +
                                                                 "' exists: pick another name or delete it first"));
            }
            // The frame of the rig of the moment in the rig's own view (beauty, its exposure and
            // transform), at full quality; kept with the rig of the version it shows.
            protocol::ViewSettings view;
            view.quality = 90;
            const unsigned httpVersion = req.version();
            const bool alive = req.keep_alive();
            hub->render().requestEncoded(view, [self = shared_from_this(), hub, name = name.value(), author, httpVersion, alive](
                                                   Result<std::shared_ptr<const EncodedFrame>> f) {
                asio::post(self->mStream.get_executor(), [self, hub, name, author, httpVersion, alive, f = std::move(f)]() {
                    auto fail = [&](const Error& e) {
                        self->send(errorResponse(httpVersion, alive, makeError(e.code, self->mState->redact(e.message))));
                    };
                    if (!f) return fail(f.error());
                    // The session closed on this node while the frame was rendered: its state
                    // folder may be another node's by now.
                    if (hub->closed()) return fail(makeError(ErrorCode::Moved, "session '" + hub->id() + "' moved while the snapshot was "
                                                                                                       "rendered: take it again"));
                    const EncodedFrame& frame = *f.value();
                    const Rig rig = hub->session().rig();
                    if (rig.version != frame.rigVersion) {
                        return fail(makeError(ErrorCode::Conflict, "the rig changed while the snapshot was rendered (version " +
                                                                       std::to_string(frame.rigVersion) + " -> " +
                                                                       std::to_string(rig.version) + "): take it again"));
                    }
                    auto out = hub->library().addSnapshot(name, rig, author.name,
                                                          std::string(reinterpret_cast<const char*>(frame.image()), frame.imageSize()),
                                                          hub->shot().width, hub->shot().height);
                    if (!out) return fail(out.error());
                    hub->libraryChanged();
                    self->send(makeResponse(httpVersion, alive, http::status::ok, "application/json", protocol::dump(out.value(), 2)));
                });
            }, /*fullQuality=*/true);
            return;
        }
        // kind/NAME, kind/NAME/load, snapshots/NAME.jpg, snapshots/NAME.thumb.jpg
        std::string rest = resource.substr(kind.size() + 1);
        std::string action;
        if (const size_t slash = rest.find('/'); slash != std::string::npos) action = rest.substr(slash + 1), rest.resize(slash);
        std::string image;
        for (const char* ext : {".thumb.jpg", ".jpg"}) {
            const std::string e = ext;
            if (snapshots && action.empty() && image.empty() && rest.size() > e.size() && rest.compare(rest.size() - e.size(), e.size(), e) == 0) {
                image = e;
                rest.resize(rest.size() - e.size());
            }
        }
        const std::string& name = rest;
        Result<Library::Entry> entry = makeError(ErrorCode::MissingData, "");
        std::shared_ptr<const Library::Snapshot> snap;
        if (snapshots) {
            auto s = library.snapshot(name);
            if (s) snap = s.value(), entry = static_cast<const Library::Entry&>(*snap);
            else entry = s.error();
        } else {
            entry = library.savedRig(name);
        }
        if (!entry) return refuse(entry.error(), http::status::not_found);
        if (!image.empty()) {
            if (!get) return notAllowed("GET, HEAD");
            auto res = makeResponse(req, http::status::ok, "image/jpeg", image == ".jpg" ? *snap->image : *snap->thumbnail);
            res.set("X-Rig-Version", std::to_string(snap->rigVersion));
            return send(std::move(res));
        }
        if (action == "load") {
            // One undoable edit: the saved rig replaces the live one (Session::replace).
            if (!post) return notAllowed("POST");
            if (!editorOnly()) return;
            auto expected = ifMatch(req);
            if (!expected) return refuse(expected.error());
            auto rig = protocol::rigFromJson(entry->rig);
            if (!rig) return refuse(rig.error());
            auto out = session.replace(rig.value(), author, expected.value());
            if (!out) return refuse(out.error());
            return accepted(out.value(), json{{"loaded", kind.substr(0, kind.size() - 1) + " " + name}});
        }
        if (!action.empty()) return refuse(makeError(ErrorCode::MissingData, "no such resource: " + kind + "/" + name + "/" + action.substr(0, 64)), http::status::not_found);
        if (get) {
            json j = json{{"name", entry->name}, {"rigVersion", entry->rigVersion}, {"by", entry->by}, {"time", entry->time}, {"rig", entry->rig}};
            if (snap) j["width"] = snap->width, j["height"] = snap->height;
            return send(makeResponse(req, http::status::ok, "application/json", protocol::dump(j, 2)));
        }
        if (!del) return notAllowed("GET, HEAD, DELETE");
        if (!editorOnly()) return;
        auto st = snapshots ? library.removeSnapshot(name) : library.removeRig(name);
        if (!st) return refuse(st.error());
        hub->libraryChanged();
        return send(makeResponse(req, http::status::ok, "application/json", protocol::dump(json{{"deleted", name}}, 2)));
    }
    if (resource == "annotations" || resource.rfind("annotations/", 0) == 0) {
        // Annotations (session/Annotations.h; docs/protocol.md "Annotations"): read, added,
        // resolved and reopened by any role, viewers included (a review note is not an edit of
        // the rig); deleted by editors. Every change sends every client the whole list.
        Annotations& notes = hub->annotations();
        if (resource == "annotations") {
            if (get) return send(makeResponse(req, http::status::ok, "application/json", protocol::dump(json{{"annotations", notes.list()}}, 2)));
            if (!post) return notAllowed("GET, HEAD, POST");
            auto body = protocol::parseJson(req.body(), MAX_BODY_BYTES, "POST annotations: the body");
            if (!body) return refuse(body.error());
            auto shape = protocol::annotationFromJson(body.value(), "annotation");
            if (!shape) return refuse(shape.error());
            auto out = notes.add(shape.value(), hub->shot().width, hub->shot().height, session.rigVersion(), author.name);
            if (!out) return refuse(out.error());
            hub->annotationsChanged();
            return send(makeResponse(req, http::status::ok, "application/json", protocol::dump(out.value(), 2)));
        }
        // annotations/N, annotations/N/resolve, annotations/N/reopen
        const std::string rest = resource.substr(12);
        const size_t slash = rest.find('/');
        const std::string n = rest.substr(0, slash), action = slash == std::string::npos ? "" : rest.substr(slash + 1);
        if (n.empty() || n.size() > 19 || n.find_first_not_of("0123456789") != std::string::npos ||
            (!action.empty() && action != "resolve" && action != "reopen")) {
            return refuse(makeError(ErrorCode::MissingData, "no such resource: annotations/" + rest.substr(0, 64) +
                                                                " (expected annotations/ID, annotations/ID/resolve or annotations/ID/reopen)"),
                          http::status::not_found);
        }
        const uint64_t id = std::stoull(n);
        if (!action.empty()) {
            if (!post) return notAllowed("POST");
            auto out = notes.setResolved(id, action == "resolve", author.name);
            if (!out) return refuse(out.error());
            hub->annotationsChanged();
            return send(makeResponse(req, http::status::ok, "application/json", protocol::dump(out.value(), 2)));
        }
        if (req.method() != http::verb::delete_) return notAllowed("DELETE");
        if (role != protocol::Role::Editor) {
            return refuse(makeError(ErrorCode::Forbidden, "a viewer token cannot delete annotations (resolve it instead)"));
        }
        if (auto st = notes.remove(id); !st) return refuse(st.error());
        hub->annotationsChanged();
        return send(makeResponse(req, http::status::ok, "application/json", protocol::dump(json{{"deleted", id}}, 2)));
    }
    if (resource == "drag") {
        // A whole drag in one request (docs/protocol.md "Drags"): begin at `from`, one update to
        // `to`, end; one edit, one undo step.
        if (!post) return notAllowed("POST");
        if (!editorOnly()) return;
        auto in = editorBody(req, "POST drag", "{\"mode\", \"light\", \"from\", \"to\"}");
        if (!in) return refuse(in.error());
        const std::optional<uint64_t> expected = in->expected;
        const json& body = in->body;
        for (auto it = body.begin(); it != body.end(); ++it) {
            if (it.key() != "mode" && it.key() != "light" && it.key() != "from" && it.key() != "to" && it.key() != "points") {
                return refuse(makeError(ErrorCode::Protocol, "POST drag: unknown field '" + it.key().substr(0, 64) +
                                                                 "' (expected mode, light, from, to, points)"));
            }
        }
        int xy[2][2] = {};
        for (int i = 0; i < 2; ++i) {
            const char* f = i == 0 ? "from" : "to";
            if (!body.contains(f) || !body[f].is_array() || body[f].size() != 2) {
                return refuse(makeError(ErrorCode::Protocol, std::string("POST drag: ") + f + ": expected a pixel [x, y]"));
            }
            for (int k = 0; k < 2; ++k) {
                const json& v = body[f][size_t(k)];
                if (!v.is_number_integer() || v.get<int64_t>() < 0 || v.get<int64_t>() > (1 << 20)) {
                    return refuse(makeError(ErrorCode::Protocol, std::string("POST drag: ") + f +
                                                                     ": expected non-negative integer pixel coordinates"));
                }
                xy[i][k] = int(v.get<int64_t>());
            }
        }
        // The begin goes through the WebSocket's codec (mode, light and points checked there).
        json begin{{"type", "drag"}, {"seq", uint64_t(0)}, {"phase", "begin"}, {"x", xy[0][0]}, {"y", xy[0][1]}};
        for (const char* f : {"mode", "light", "points"}) {
            if (body.contains(f)) begin[f] = body[f];
        }
        auto parsed = protocol::clientMessageFromJson(begin);
        if (!parsed) return refuse(parsed.error());
        const auto& m = std::get<protocol::DragMessage>(parsed.value());
        DragStart start;
        start.mode = protocol::parseDragMode(m.mode).value();
        start.light = m.light;
        start.x = m.x;
        start.y = m.y;
        start.points = m.points;
        const int toX = xy[1][0], toY = xy[1][1];
        const std::optional<uint64_t> ifVersion = expected;
        hub->render().requestPickerJob([self = shared_from_this(), hub, start, toX, toY, ifVersion, version, keepAlive, author](
                                           const Picker& picker, const DeepBuffer& shot) {
            // Solved here (render thread); applied and answered on the connection's strand.
            Result<std::pair<json, std::vector<protocol::Change>>> solved = [&]() -> Result<std::pair<json, std::vector<protocol::Change>>> {
                auto g = beginDrag(picker, shot, hub->session().rig(), start);
                if (!g) return g.error();
                auto step = dragTo(picker, shot, g.value(), toX, toY);
                if (!step) return step.error();
                return std::make_pair(json{{"grab", toJson(g.value())}, {"step", toJson(step.value())}}, step->changes);
            }();
            asio::post(self->mStream.get_executor(), [self, hub, solved = std::move(solved), ifVersion, version, keepAlive, author]() mutable {
                auto fail = [&](const Error& e) {
                    hub->metrics().editRefused(hub->id());
                    self->send(errorResponse(version, keepAlive, makeError(e.code, self->mState->redact(e.message)),
                                             e.code == ErrorCode::MissingData ? std::optional(http::status::bad_request) : std::nullopt));
                };
                if (!solved) return fail(solved.error());
                json answer{{"drag", solved->first}};
                uint64_t rigVersion = hub->session().rigVersion();
                if (!solved->second.empty()) {
                    auto out = hub->session().edit(solved->second, author, std::nullopt, ifVersion);
                    if (!out) return fail(out.error());
                    hub->published(out.value(), nullptr);
                    rigVersion = out->info.rigVersion;
                } else if (ifVersion && *ifVersion != rigVersion) {
                    return fail(makeError(ErrorCode::Conflict, "the rig is at version " + std::to_string(rigVersion) + ", not " +
                                                                   std::to_string(*ifVersion) + "; nothing was changed"));
                }
                answer["rigVersion"] = rigVersion;
                auto res = makeResponse(version, keepAlive, http::status::ok, "application/json", protocol::dump(answer, 2));
                res.set(http::field::etag, etag(rigVersion));
                self->send(std::move(res));
            });
        });
        return;
    }
    if (resource == "export.glb") {
        // The scene with the rig's lights (dfb/server/GltfExport.h; docs/protocol.md "Export"):
        // read like the rig, by any role. Built on the render thread's job queue (reading and
        // writing a scene takes ~0.1-1 s; the I/O thread serves every session meanwhile).
        if (!get) return notAllowed("GET, HEAD");
        const Rig rig = session.rig();
        if (rig.lights.empty()) {
            return refuse(makeError(ErrorCode::MissingData, "session '" + hub->id() + "': the rig has no lights, so there is nothing to "
                                                                                      "export (add a light first)"),
                          http::status::conflict);
        }
        const std::string scene = session.scenePath();
        hub->render().requestPickerJob([self = shared_from_this(), hub, rig, scene, version, keepAlive](const Picker&, const DeepBuffer&) {
            auto glb = scene.empty() ? Result<std::string>(makeError(ErrorCode::FileNotFound, "the session has no scene file"))
                                     : exportGltf(scene, rig);
            Response res;
            if (!glb) {
                // The scene is the server's: a file that went missing or broke is its failure,
                // reported without its folders.
                const Error e = makeError(glb.error().code, "session '" + hub->id() + "': cannot export the scene: " +
                                                                self->mState->redact(glb.error().message));
                res = errorResponse(version, keepAlive, e, http::status::internal_server_error);
            } else {
                res = makeResponse(version, keepAlive, http::status::ok, "model/gltf-binary", std::move(glb.value()));
                res.set(http::field::etag, etag(rig.version));
                res.set(http::field::content_disposition, "attachment; filename=\"" + hub->id() + ".glb\"");
            }
            asio::post(self->mStream.get_executor(), [self, res = std::move(res)]() mutable { self->send(std::move(res)); });
        });
        return;
    }
    if (resource == "final") {
        // Cycles final renders (net/FinalRenders.h; docs/protocol.md "Final render"): the state
        // for anyone, start (POST) and cancel (DELETE) for editors.
        FinalRenders& finals = hub->finals();
        if (get) return send(makeResponse(req, http::status::ok, "application/json", protocol::dump(finals.status(), 2)));
        if (!post && req.method() != http::verb::delete_) return notAllowed("GET, HEAD, POST, DELETE");
        if (!editorOnly()) return;
        Result<json> out = makeError(ErrorCode::Protocol, "");
        if (post) {
            auto in = req.body().empty() ? Result<EditorBody>(EditorBody{std::nullopt, json::object()})
                                         : editorBody(req, "POST final", "{\"samples\", \"directOnly\"}");
            if (!in) return refuse(in.error());
            FinalRenderOptions o;
            for (auto it = in->body.begin(); it != in->body.end(); ++it) {
                if (it.key() == "samples" && it->is_number_integer() && it->get<int64_t>() >= 1 && it->get<int64_t>() <= (1 << 20)) {
                    o.samples = int(it->get<int64_t>());
                } else if (it.key() == "directOnly" && it->is_boolean()) {
                    o.directOnly = it->get<bool>();
                } else {
                    return refuse(makeError(ErrorCode::Protocol, "POST final: '" + it.key().substr(0, 64) +
                                                                     "' is not a field (samples: an integer, directOnly: a boolean)"));
                }
            }
            out = finals.start(session.rig(), o, session.assetDirectory());
        } else {
            out = finals.cancel();
        }
        // A render of another version running, nothing to cancel: 409 (not If-Match's 412).
        const bool busy = out ? false : out.error().code == ErrorCode::Conflict || out.error().code == ErrorCode::MissingData;
        if (!out) return refuse(out.error(), busy ? std::optional(http::status::conflict) : std::nullopt);
        return send(makeResponse(req, post ? http::status::accepted : http::status::ok, "application/json", protocol::dump(out.value(), 2)));
    }
    if (resource == "final.exr" || resource == "final.png") {
        if (!get) return notAllowed("GET, HEAD");
        const bool exr = resource == "final.exr";
        // final.png?exposure=S&viewTransform=T: in a viewer's own view, as its live frames.
        auto view = protocol::viewFromQuery(query);
        if (!view) return refuse(view.error());
        if (view->output != "beauty" || (exr && !view->isDefaultImage())) {
            return refuse(makeError(ErrorCode::InvalidValue, resource + ": only final.png takes query parameters, and only exposure "
                                                                        "and viewTransform"));
        }
        std::optional<ViewTransform> transform;
        if (view->viewTransform == "srgb") transform = ViewTransform::Srgb;
        if (view->viewTransform == "filmic") transform = ViewTransform::Filmic;
        auto bytes = hub->finals().encoded(exr, view->exposureStops, transform);
        if (!bytes) return refuse(bytes.error(), http::status::internal_server_error);
        if (!bytes.value()) {
            return refuse(makeError(ErrorCode::MissingData, "session '" + hub->id() + "' has no finished final render (POST .../final)"),
                          http::status::conflict);
        }
        auto res = makeResponse(req, http::status::ok, exr ? "image/x-exr" : "image/png", *bytes.value());
        res.set(http::field::etag, etag(hub->finals().imageVersion()));
        return send(std::move(res));
    }
    if (resource == "pick") {
        if (!get) return notAllowed("GET, HEAD");
        int xy[2] = {0, 0};
        for (int i = 0; i < 2; ++i) {
            auto v = queryParam(query, i == 0 ? "x" : "y");
            if (!v || v->empty() || v->size() > 7 || v->find_first_not_of("0123456789") != std::string::npos) {
                return refuse(makeError(ErrorCode::InvalidValue, std::string("pick: query parameter ") + (i == 0 ? "x" : "y") +
                                                                     " must be a non-negative integer pixel coordinate"));
            }
            xy[i] = std::stoi(*v);
        }
        hub->render().requestPick(xy[0], xy[1], [self = shared_from_this(), version, keepAlive](Result<json> r) {
            Response res = r ? makeResponse(version, keepAlive, http::status::ok, "application/json", protocol::dump(r.value(), 2))
                             : errorResponse(version, keepAlive, makeError(r.error().code, self->mState->redact(r.error().message)));
            asio::post(self->mStream.get_executor(), [self, res = std::move(res)]() mutable { self->send(std::move(res)); });
        });
        return;
    }
    send(errorResponse(req, ErrorCode::MissingData, "no such resource: " + std::string(req.target().substr(0, req.target().find('?')))));
}

void HttpSession::sendRefusal(const Request& req, const Error& e) {
    send(errorResponse(req.version(), req.keep_alive(), makeError(e.code, mState->redact(e.message))));
}

void HttpSession::send(Response&& res) {
    auto sp = std::make_shared<Response>(std::move(res));
    mResponse = sp;
    http::async_write(mStream, *sp, beast::bind_front_handler(&HttpSession::onWrite, shared_from_this(), sp->need_eof()));
}

void HttpSession::onWrite(bool close, error_code ec, size_t) {
    if (ec) return fail(ec, "http write");
    mResponse.reset();
    if (close) return shutdown();
    doRead();
}

} // namespace dfb::net
