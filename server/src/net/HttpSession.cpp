#include "net/HttpSession.h"

#include "net/WebSocketSession.h"

#include <dfb/protocol/Codec.h>
#include <dfb/server/ImageCodec.h>

#include <algorithm>
#include <cctype>
#include <string_view>

namespace dfb::web {
std::string_view asset(std::string_view name);
}

namespace dfb::net {
namespace {

// Requests larger than this are refused: no v0 endpoint takes a body worth more.
constexpr size_t MAX_BODY_BYTES = 1 << 20;

http::response<http::string_body> makeResponse(const http::request<http::string_body>& req, http::status status,
                                               std::string_view contentType, std::string body) {
    http::response<http::string_body> res{status, req.version()};
    res.set(http::field::server, "dfb-server");
    res.set(http::field::content_type, std::string(contentType));
    res.set(http::field::cache_control, "no-store");
    res.keep_alive(req.keep_alive());
    res.body() = std::move(body);
    res.prepare_payload();
    return res;
}

// The value of `name` in a URL query string, percent-decoded ("" when absent).
std::string queryParameter(const std::string& query, const std::string& name) {
    size_t at = 0;
    while (at <= query.size()) {
        const size_t amp = std::min(query.find('&', at), query.size());
        const std::string pair = query.substr(at, amp - at);
        if (pair.compare(0, name.size() + 1, name + "=") == 0) {
            std::string out;
            for (size_t i = name.size() + 1; i < pair.size(); ++i) {
                if (pair[i] == '%' && i + 2 < pair.size() && std::isxdigit(static_cast<unsigned char>(pair[i + 1])) &&
                    std::isxdigit(static_cast<unsigned char>(pair[i + 2]))) {
                    out += char(std::stoi(pair.substr(i + 1, 2), nullptr, 16));
                    i += 2;
                } else {
                    out += pair[i] == '+' ? ' ' : pair[i];
                }
            }
            return out;
        }
        at = amp + 1;
    }
    return "";
}

http::response<http::string_body> errorResponse(const http::request<http::string_body>& req, http::status status,
                                                ErrorCode code, const std::string& message) {
    return makeResponse(req, status, "application/json", protocol::encodeError(code, message, std::nullopt));
}

} // namespace

HttpSession::HttpSession(tcp::socket&& socket, std::shared_ptr<SharedState> state)
    : mStream(std::move(socket)), mState(std::move(state)) {}

void HttpSession::run() {
    asio::dispatch(mStream.get_executor(), beast::bind_front_handler(&HttpSession::doRead, shared_from_this()));
}

void HttpSession::doRead() {
    mParser.emplace();
    mParser->body_limit(MAX_BODY_BYTES);
    mStream.expires_after(std::chrono::seconds(60));
    http::async_read(mStream, mBuffer, *mParser, beast::bind_front_handler(&HttpSession::onRead, shared_from_this()));
}

void HttpSession::onRead(error_code ec, size_t) {
    if (ec == http::error::end_of_stream) {
        mStream.socket().shutdown(tcp::socket::shutdown_send, ec);
        return;
    }
    if (ec) return fail(ec, "http read");
    if (websocket::is_upgrade(mParser->get())) {
        mStream.expires_never();
        auto req = mParser->release();
        if (req.target() != "/v1/ws") {
            send(errorResponse(req, http::status::not_found, ErrorCode::Protocol, "WebSocket endpoint is /v1/ws"));
            return;
        }
        std::make_shared<WebSocketSession>(mStream.release_socket(), mState)->run(std::move(req));
        return;
    }
    handle(mParser->release());
}

void HttpSession::handle(http::request<http::string_body>&& req) {
    std::string target(req.target());
    const size_t q = target.find('?');
    const std::string path = target.substr(0, q);
    if (req.method() != http::verb::get && req.method() != http::verb::head) {
        return send(errorResponse(req, http::status::method_not_allowed, ErrorCode::Protocol,
                                  "method not allowed on " + path));
    }
    if (path == "/" || path == "/index.html") {
        return send(makeResponse(req, http::status::ok, "text/html; charset=utf-8", std::string(web::asset("index.html"))));
    }
    if (path == "/healthz") return send(makeResponse(req, http::status::ok, "text/plain", "ok\n"));
    if (path == "/favicon.ico") return send(makeResponse(req, http::status::no_content, "image/x-icon", ""));
    if (path == "/v1/rig") {
        return send(makeResponse(req, http::status::ok, "application/json", protocol::toJson(mState->session().rig()).dump(2)));
    }
    if (path == "/v1/session") {
        return send(makeResponse(req, http::status::ok, "application/json", mState->session().description().dump(2)));
    }
    if (path == "/v1/frame.png" || path == "/v1/frame.jpg" || path == "/v1/frame.jpeg" || path == "/v1/frame.exr") {
        // ?output=beauty | light:NAME | shadow:NAME | layer:NAME
        OutputRequest request;
        request.format = path.substr(path.rfind('.') + 1);
        if (q != std::string::npos) {
            const std::string output = queryParameter(target.substr(q + 1), "output");
            if (!output.empty()) request.output = output;
        }
        if (auto s = checkOutputRequest(request); !s) {
            return send(errorResponse(req, http::status::bad_request, s.error().code, s.error().message));
        }
        return sendFrame(std::move(request), req.version(), req.keep_alive());
    }
    send(errorResponse(req, http::status::not_found, ErrorCode::MissingData, "no such resource: " + path));
}

void HttpSession::sendFrame(OutputRequest request, unsigned version, bool keepAlive) {
    // Rendering and encoding happen on the render thread; the response is written back here.
    mState->render().requestOutput(std::move(request), [self = shared_from_this(), version, keepAlive](Result<EncodedImage> image, uint64_t rigVersion) {
        http::request<http::string_body> req;
        req.version(version);
        req.keep_alive(keepAlive);
        http::response<http::string_body> res;
        if (!image) {
            const bool badRequest = image.error().code == ErrorCode::InvalidValue || image.error().code == ErrorCode::MissingData;
            res = errorResponse(req, badRequest ? http::status::bad_request : http::status::internal_server_error,
                                image.error().code, image.error().message);
        } else {
            res = makeResponse(req, http::status::ok, image->contentType, std::string(image->bytes.begin(), image->bytes.end()));
            res.set("X-Rig-Version", std::to_string(rigVersion));
        }
        asio::post(self->mStream.get_executor(), [self, r = std::move(res)]() mutable { self->send(std::move(r)); });
    });
}

void HttpSession::send(http::response<http::string_body>&& res) {
    auto sp = std::make_shared<http::response<http::string_body>>(std::move(res));
    mResponse = sp;
    http::async_write(mStream, *sp,
                      beast::bind_front_handler(&HttpSession::onWrite, shared_from_this(), sp->need_eof()));
}

void HttpSession::onWrite(bool close, error_code ec, size_t) {
    if (ec) return fail(ec, "http write");
    mResponse.reset();
    if (close) {
        mStream.socket().shutdown(tcp::socket::shutdown_send, ec);
        return;
    }
    doRead();
}

} // namespace dfb::net
