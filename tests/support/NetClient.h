#pragma once
// Test support: a plain synchronous HTTP request and a WebSocket client of protocol v1 over
// loopback, written with Beast directly (independent of dfb-client, so tests see the wire).

#include <utility> // Boost 1.74 asio needs std::exchange declared first
#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <sys/socket.h>
#include <sys/time.h>

namespace dfb::test {

namespace beast = boost::beast;
namespace asio = boost::asio;
using tcp = asio::ip::tcp;

inline void setReceiveTimeout(tcp::socket& s, std::chrono::milliseconds t) {
    timeval tv{};
    tv.tv_sec = static_cast<time_t>(t.count() / 1000);
    tv.tv_usec = static_cast<suseconds_t>((t.count() % 1000) * 1000);
    ::setsockopt(s.native_handle(), SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
}

struct HttpReply {
    int status = 0;
    std::string body;
    std::map<std::string, std::string> headers;
    nlohmann::json json() const { return nlohmann::json::parse(body, nullptr, false); }
};

/// One request to 127.0.0.1:port; `token` goes in "Authorization: Bearer".
inline HttpReply http(const std::string& port, const std::string& method, const std::string& target, const std::string& token = "",
                      const std::string& body = "", std::map<std::string, std::string> headers = {}) {
    asio::io_context ioc;
    tcp::socket socket(ioc);
    tcp::resolver resolver(ioc);
    asio::connect(socket, resolver.resolve("127.0.0.1", port));
    setReceiveTimeout(socket, std::chrono::seconds(60));
    beast::http::request<beast::http::string_body> req{beast::http::string_to_verb(method), target, 11};
    req.set(beast::http::field::host, "127.0.0.1");
    if (!token.empty()) req.set(beast::http::field::authorization, "Bearer " + token);
    for (const auto& [k, v] : headers) req.set(k, v);
    req.body() = body;
    req.prepare_payload();
    beast::http::write(socket, req);
    beast::flat_buffer buf;
    beast::http::response_parser<beast::http::string_body> parser;
    parser.body_limit(64u << 20);
    beast::http::read(socket, buf, parser);
    auto res = parser.release();
    HttpReply r;
    r.status = int(res.result_int());
    r.body = res.body();
    for (const auto& f : res) r.headers[std::string(f.name_string())] = std::string(f.value());
    return r;
}

/// A WebSocket client of one session. Messages are read one at a time; the frames and the text
/// messages are kept apart.
class WsClient {
public:
    struct Frame {
        uint64_t rigVersion = 0;
        std::vector<uint8_t> bytes; // the whole binary message, header included
    };

    /// `receiveBuffer` > 0 shrinks the socket's receive buffer (set before connecting, so the
    /// TCP window stays small): a client that does not read then really stalls the server's writes.
    WsClient(const std::string& port, const std::string& session, const std::string& token, int receiveBuffer = 0) : mWs(mIoc) {
        tcp::resolver resolver(mIoc);
        auto endpoints = resolver.resolve("127.0.0.1", port);
        if (receiveBuffer > 0) {
            mWs.next_layer().open(tcp::v4());
            mWs.next_layer().set_option(asio::socket_base::receive_buffer_size(receiveBuffer));
        }
        mWs.next_layer().connect(*endpoints.begin());
        setReceiveTimeout(mWs.next_layer(), std::chrono::seconds(60));
        mWs.read_message_max(64u << 20);
        mWs.handshake("127.0.0.1", "/v1/sessions/" + session + "/ws?token=" + token);
    }
    void send(const std::string& text) {
        mWs.text(true);
        mWs.write(asio::buffer(text));
    }
    void send(const nlohmann::json& j) { send(j.dump()); }
    void sendBinary(const std::string& bytes) {
        mWs.binary(true);
        mWs.write(asio::buffer(bytes));
    }
    /// Reads one message; frames go to frames(), text is returned (null for a frame).
    nlohmann::json readOne() {
        beast::flat_buffer buf;
        mWs.read(buf);
        if (!mWs.got_text()) {
            const auto* p = static_cast<const uint8_t*>(buf.data().data());
            Frame f;
            f.bytes.assign(p, p + buf.size());
            for (int i = 7; i >= 0; --i) f.rigVersion = (f.rigVersion << 8) | p[16 + i];
            mFrames.push_back(std::move(f));
            return nullptr;
        }
        auto j = nlohmann::json::parse(beast::buffers_to_string(buf.data()));
        mTexts.push_back(j);
        return j;
    }
    /// The next text message whose type is not one of `skip` (default: presence).
    nlohmann::json nextText(const std::vector<std::string>& skip = {"presence"}) {
        for (;;) {
            auto j = readOne();
            if (j.is_null()) continue;
            if (std::find(skip.begin(), skip.end(), j.value("type", "")) == skip.end()) return j;
        }
    }
    /// Reads until a frame showing at least `version` arrives; returns it.
    Frame frameAtLeast(uint64_t version) {
        for (;;) {
            for (const auto& f : mFrames) {
                if (f.rigVersion >= version) return f;
            }
            readOne();
        }
    }
    /// Why the server closed the connection (after a read failed with "closed").
    const beast::websocket::close_reason& closeReason() const { return mWs.reason(); }
    const std::vector<Frame>& frames() const { return mFrames; }
    const std::vector<nlohmann::json>& texts() const { return mTexts; }
    void close() {
        beast::error_code ec;
        mWs.close(beast::websocket::close_code::normal, ec);
    }

private:
    asio::io_context mIoc;
    beast::websocket::stream<tcp::socket> mWs;
    std::vector<Frame> mFrames;
    std::vector<nlohmann::json> mTexts;
};

} // namespace dfb::test
