#include "Connection.h"

#include <dfb/protocol/Json.h>

#include <utility> // before Boost 1.74's asio, which uses std::exchange without it

#include <boost/asio.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>

#include <openssl/ssl.h>

#include <optional>

#include <sys/socket.h>
#include <sys/time.h>

namespace dfb::client {

namespace {
// The server's text messages (a welcome with a rig of the largest size) stay far below this.
constexpr size_t MAX_SERVER_TEXT_BYTES = 64u << 20;
} // namespace

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace asio = boost::asio;
using tcp = asio::ip::tcp;

Result<Url> parseUrl(const std::string& text) {
    std::string rest = text;
    Url u;
    for (const char* scheme : {"http://", "ws://", "https://", "wss://"}) {
        if (rest.rfind(scheme, 0) == 0) {
            rest = rest.substr(std::strlen(scheme));
            u.tls = std::strcmp(scheme, "https://") == 0 || std::strcmp(scheme, "wss://") == 0;
        }
    }
    if (const size_t q = rest.find('?'); q != std::string::npos) {
        // ?session=ID&token=T, as in the links dfb-server prints.
        std::string query = rest.substr(q + 1);
        rest = rest.substr(0, q);
        size_t start = 0;
        while (start <= query.size()) {
            size_t end = query.find('&', start);
            if (end == std::string::npos) end = query.size();
            const std::string item = query.substr(start, end - start);
            const size_t eq = item.find('=');
            if (eq != std::string::npos && item.substr(0, eq) == "session") u.session = item.substr(eq + 1);
            if (eq != std::string::npos && item.substr(0, eq) == "token") u.token = item.substr(eq + 1);
            start = end + 1;
        }
    }
    const size_t slash = rest.find('/');
    u.path = slash == std::string::npos ? "/" : rest.substr(slash);
    const std::string hostPort = rest.substr(0, slash);
    if (hostPort.empty()) return makeError(ErrorCode::InvalidValue, "'" + text + "': no host");
    if (hostPort[0] == '[') { // [v6]:port
        const size_t close = hostPort.find(']');
        if (close == std::string::npos) return makeError(ErrorCode::InvalidValue, "'" + text + "': bad IPv6 host");
        u.host = hostPort.substr(1, close - 1);
        u.port = close + 1 < hostPort.size() && hostPort[close + 1] == ':' ? hostPort.substr(close + 2) : "8080";
    } else {
        const size_t colon = hostPort.rfind(':');
        u.host = hostPort.substr(0, colon);
        u.port = colon == std::string::npos ? "8080" : hostPort.substr(colon + 1);
    }
    if (u.port.empty() || u.port.find_first_not_of("0123456789") != std::string::npos) {
        return makeError(ErrorCode::InvalidValue, "'" + text + "': bad port");
    }
    return u;
}

namespace {
// Blocking sockets with a receive/send deadline: sync Beast calls then fail instead of hanging.
void setDeadline(tcp::socket& s, std::chrono::milliseconds timeout) {
    timeval tv{};
    tv.tv_sec = static_cast<time_t>(timeout.count() / 1000);
    tv.tv_usec = static_cast<suseconds_t>((timeout.count() % 1000) * 1000);
    ::setsockopt(s.native_handle(), SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    ::setsockopt(s.native_handle(), SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
}

Error netError(const std::string& what, const beast::error_code& ec) {
    std::string m = ec.message();
    if (ec == asio::error::would_block || ec == asio::error::try_again || ec == asio::error::timed_out || ec == beast::error::timeout) {
        m = "timed out";
    }
    return makeError(ErrorCode::Network, what + ": " + m);
}
} // namespace

// Runs one async operation started by `start` for at most `timeout`: a blocking read with
// SO_RCVTIMEO would not do, since Asio's synchronous reads poll again without a limit. On timeout
// the socket's operations are cancelled and the error is timed_out.
template <typename Start>
beast::error_code runFor(asio::io_context& ioc, tcp::socket& socket, std::chrono::milliseconds timeout, Start start) {
    beast::error_code result = asio::error::would_block;
    start([&](beast::error_code e, size_t) { result = e; });
    ioc.restart();
    // One handler at a time until ours ran: other work (the WebSocket's keep-alive timer,
    // Connection::keepAlive) may stay pending, so running until the context is out of work would
    // wait for the whole timeout.
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (result == asio::error::would_block && ioc.run_one_until(deadline) != 0) {
    }
    if (result == asio::error::would_block) {
        beast::error_code ignored;
        socket.cancel(ignored);
        ioc.restart();
        while (result == asio::error::would_block && ioc.run_one() != 0) {
        }
        return asio::error::timed_out;
    }
    return result;
}

namespace {
using TlsSocket = asio::ssl::stream<tcp::socket>;

// A client TLS context: the system's certificates, plus `caFile` when given.
Result<std::shared_ptr<asio::ssl::context>> tlsContext(const Url& url) {
    auto ctx = std::make_shared<asio::ssl::context>(asio::ssl::context::tls_client);
    beast::error_code ec;
    ctx->set_default_verify_paths(ec);
    if (!url.caFile.empty()) {
        ctx->load_verify_file(url.caFile, ec);
        if (ec) return makeError(ErrorCode::InvalidValue, "--ca-cert " + url.caFile + ": " + ec.message());
    }
    ctx->set_verify_mode(asio::ssl::verify_peer);
    return ctx;
}

// TLS on a connected socket: the server's certificate must be valid for the URL's host (SNI set).
Status tlsHandshake(TlsSocket& s, const Url& url) {
    if (!::SSL_set_tlsext_host_name(s.native_handle(), url.host.c_str())) {
        return makeError(ErrorCode::Network, "connecting to " + url.host + ":" + url.port + ": TLS: cannot set the server name");
    }
    s.set_verify_callback(asio::ssl::host_name_verification(url.host));
    beast::error_code ec;
    s.handshake(asio::ssl::stream_base::client, ec);
    if (ec) {
        return makeError(ErrorCode::Network, "connecting to " + url.host + ":" + url.port + ": TLS handshake: " + ec.message() +
                                                 (url.caFile.empty() ? " (a self-signed server needs --ca-cert)" : ""));
    }
    return okStatus();
}
} // namespace

struct Connection::Impl {
    asio::io_context ioc;
    std::chrono::milliseconds timeout{30000};
    std::shared_ptr<asio::ssl::context> tls;
    // One of the two, by the URL's scheme.
    std::optional<websocket::stream<tcp::socket>> plain;
    std::optional<websocket::stream<TlsSocket>> secure;
    beast::flat_buffer buffer;

    tcp::socket& socket() { return plain ? plain->next_layer() : secure->next_layer().next_layer(); }
    template <typename F> auto withWs(F&& f) { return plain ? f(*plain) : f(*secure); }
};

Connection::Connection(std::unique_ptr<Impl> impl) : mImpl(std::move(impl)) {}
Connection::~Connection() { close(); }

Result<std::unique_ptr<Connection>> Connection::open(const Url& url, const std::string& target, std::chrono::milliseconds timeout) {
    auto impl = std::make_unique<Impl>();
    if (url.tls) {
        auto ctx = tlsContext(url);
        if (!ctx) return ctx.error();
        impl->tls = ctx.value();
        impl->secure.emplace(impl->ioc, *impl->tls);
    } else {
        impl->plain.emplace(impl->ioc);
    }
    beast::error_code ec;
    tcp::resolver resolver(impl->ioc);
    auto results = resolver.resolve(url.host, url.port, ec);
    if (ec) return netError("resolving " + url.host, ec);
    asio::connect(impl->socket(), results, ec);
    if (ec) return netError("connecting to " + url.host + ":" + url.port, ec);
    setDeadline(impl->socket(), timeout);
    // Edits are small: send them at once, not after the server's delayed ACK (Nagle).
    impl->socket().set_option(tcp::no_delay(true), ec);
    if (impl->secure) {
        if (auto s = tlsHandshake(impl->secure->next_layer(), url); !s) return s.error();
    }
    impl->timeout = timeout;
    websocket::response_type res;
    // Asynchronous (run for at most `timeout`): Boost 1.74's synchronous handshake leaves `res`
    // empty when the upgrade is declined, and the refusal's status and body are what tell a client
    // why (a token, or a session moving between the nodes of a fleet).
    ec = runFor(impl->ioc, impl->socket(), timeout, [&](auto handler) {
        impl->withWs([&](auto& ws) {
            ws.read_message_max(256u << 20);
            ws.async_handshake(res, url.host + ":" + url.port, target, [handler](beast::error_code e) mutable { handler(e, 0); });
        });
    });
    if (ec == websocket::error::upgrade_declined) {
        // The server said why (no token, unknown session): its JSON error, verbatim.
        auto parsed = protocol::parseJson(res.body(), 1 << 20, "the server's answer");
        const nlohmann::json j = parsed ? std::move(parsed.value()) : nlohmann::json();
        const ErrorCode c = errorCodeFromString(j.is_object() ? j.value("code", "") : "").value_or(ErrorCode::Protocol);
        const std::string message = j.is_object() && j["message"].is_string() ? j["message"].get<std::string>() : res.body();
        return makeError(c, message + " (HTTP " + std::to_string(res.result_int()) + ")");
    }
    if (ec) return netError("WebSocket handshake with " + url.host + ":" + url.port, ec);
    return std::unique_ptr<Connection>(new Connection(std::move(impl)));
}

Status Connection::sendText(const std::string& text) {
    beast::error_code ec;
    mImpl->withWs([&](auto& ws) {
        ws.text(true);
        ws.write(asio::buffer(text), ec);
    });
    if (ec) return netError("sending", ec);
    return okStatus();
}

Result<ServerMessage> Connection::receive() { return receive(mImpl->timeout); }

Result<ServerMessage> Connection::receive(std::chrono::milliseconds timeout) {
    beast::error_code ec;
    mImpl->buffer.consume(mImpl->buffer.size());
    ec = runFor(mImpl->ioc, mImpl->socket(), timeout,
                [&](auto handler) { mImpl->withWs([&](auto& ws) { ws.async_read(mImpl->buffer, handler); }); });
    if (ec) return netError("receiving", ec);
    if (mImpl->withWs([](auto& ws) { return ws.got_text(); })) {
        auto j = protocol::parseJson(beast::buffers_to_string(mImpl->buffer.data()), MAX_SERVER_TEXT_BYTES, "server message");
        if (!j || !j->is_object()) return makeError(ErrorCode::Protocol, "server sent invalid JSON");
        return ServerMessage{TextMessage{std::move(j.value())}};
    }
    const auto* data = static_cast<const uint8_t*>(mImpl->buffer.data().data());
    const size_t size = mImpl->buffer.size();
    auto h = protocol::readFrameHeader(data, size);
    if (!h) return h.error();
    FrameMessage f{h.value(), std::vector<uint8_t>(data + protocol::FRAME_HEADER_BYTES, data + size)};
    return ServerMessage{std::move(f)};
}

void Connection::keepAlive(std::chrono::milliseconds idle) {
    mImpl->withWs([&](auto& ws) {
        websocket::stream_base::timeout opt{};
        opt.handshake_timeout = mImpl->timeout;
        opt.idle_timeout = idle;
        opt.keep_alive_pings = true;
        ws.set_option(opt);
    });
}

void Connection::shutdown() {
    if (!mImpl) return;
    ::shutdown(mImpl->socket().native_handle(), SHUT_RDWR);
}

void Connection::close() {
    if (!mImpl || !mImpl->withWs([](auto& ws) { return ws.is_open(); })) return;
    beast::error_code ec;
    mImpl->withWs([&](auto& ws) { ws.close(websocket::close_code::normal, ec); });
}

Result<HttpResponse> httpRequest(const Url& url, const std::string& method, const std::string& target, const std::string& token,
                                 const std::string& body, const std::string& ifMatch, std::chrono::milliseconds timeout,
                                 const std::string& name) {
    asio::io_context ioc;
    beast::error_code ec;
    tcp::resolver resolver(ioc);
    auto results = resolver.resolve(url.host, url.port, ec);
    if (ec) return netError("resolving " + url.host, ec);
    std::shared_ptr<asio::ssl::context> tls;
    std::optional<TlsSocket> secure;
    std::optional<tcp::socket> plain;
    if (url.tls) {
        auto ctx = tlsContext(url);
        if (!ctx) return ctx.error();
        tls = ctx.value();
        secure.emplace(ioc, *tls);
    } else {
        plain.emplace(ioc);
    }
    tcp::socket& socket = plain ? *plain : secure->next_layer();
    asio::connect(socket, results, ec);
    if (ec) return netError("connecting to " + url.host + ":" + url.port, ec);
    setDeadline(socket, timeout);
    if (secure) {
        if (auto s = tlsHandshake(*secure, url); !s) return s.error();
    }
    http::request<http::string_body> req{http::string_to_verb(method), target, 11};
    req.set(http::field::host, url.host);
    req.set(http::field::user_agent, "dfb-client");
    if (!token.empty()) req.set(http::field::authorization, "Bearer " + token);
    if (!ifMatch.empty()) req.set(http::field::if_match, ifMatch);
    if (!name.empty()) req.set("X-Dfb-Name", name);
    if (!body.empty()) {
        req.set(http::field::content_type, "application/json");
        req.body() = body;
    }
    req.prepare_payload();
    beast::flat_buffer buffer;
    http::response_parser<http::string_body> parser;
    parser.body_limit(512u << 20);
    auto exchange = [&](auto& stream) {
        http::write(stream, req, ec);
        if (ec) return;
        ec = runFor(ioc, socket, timeout, [&](auto handler) { http::async_read(stream, buffer, parser, handler); });
    };
    if (plain) exchange(*plain);
    else exchange(*secure);
    if (ec) return netError(method + " " + target, ec);
    auto res = parser.release();
    HttpResponse out;
    out.status = int(res.result_int());
    out.body = std::move(res.body());
    out.etag = std::string(res[http::field::etag]);
    out.rigVersion = std::string(res["X-Rig-Version"]);
    return out;
}

} // namespace dfb::client
