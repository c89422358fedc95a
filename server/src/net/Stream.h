#pragma once
// A connection's byte stream: plain TCP, or TLS over TCP when the server was given a
// certificate (--tls-cert/--tls-key: HTTPS and WSS on the server's one port). One type for both
// so that HttpSession and WebSocketSession (and the hand-over of an upgraded connection, TLS
// state included) stay single classes; Beast's own flex example doubles every session class
// through CRTP instead. Models Beast's AsyncStream: reads and writes go to the active layer, the
// lowest layer is always the beast::tcp_stream (timeouts, socket options, close), and the
// WebSocket teardown of the active layer is found through ADL.

#include "net/Beast.h"

#include <boost/asio/ssl.hpp>
#include <boost/beast/ssl.hpp>

#include <utility>
#include <variant>

namespace dfb::net {

using TlsStream = beast::ssl_stream<beast::tcp_stream>;

class Stream {
public:
    using executor_type = beast::tcp_stream::executor_type;
    using next_layer_type = beast::tcp_stream;

    /// Plain TCP.
    explicit Stream(tcp::socket&& socket) : mStream(std::in_place_type<beast::tcp_stream>, std::move(socket)) {}
    /// TLS (server side) with `tls`'s certificate; the handshake is the caller's (handshake()).
    Stream(tcp::socket&& socket, asio::ssl::context& tls) : mStream(std::in_place_type<TlsStream>, std::move(socket), tls) {}
    Stream(Stream&&) = default;

    bool tls() const { return std::holds_alternative<TlsStream>(mStream); }
    executor_type get_executor() { return next_layer().get_executor(); }
    /// The TCP stream under either kind (what beast::get_lowest_layer returns).
    beast::tcp_stream& next_layer() {
        if (auto* t = std::get_if<TlsStream>(&mStream)) return t->next_layer();
        return std::get<beast::tcp_stream>(mStream);
    }
    TlsStream& tlsStream() { return std::get<TlsStream>(mStream); }

    template <class MutableBuffers, class Handler> auto async_read_some(const MutableBuffers& buffers, Handler&& handler) {
        if (auto* t = std::get_if<TlsStream>(&mStream)) return t->async_read_some(buffers, std::forward<Handler>(handler));
        return std::get<beast::tcp_stream>(mStream).async_read_some(buffers, std::forward<Handler>(handler));
    }
    template <class ConstBuffers, class Handler> auto async_write_some(const ConstBuffers& buffers, Handler&& handler) {
        if (auto* t = std::get_if<TlsStream>(&mStream)) return t->async_write_some(buffers, std::forward<Handler>(handler));
        return std::get<beast::tcp_stream>(mStream).async_write_some(buffers, std::forward<Handler>(handler));
    }

    // WebSocket close: the active layer's teardown (TLS close_notify, then TCP).
    friend void teardown(beast::role_type role, Stream& s, error_code& ec) {
        using beast::websocket::teardown;
        if (auto* t = std::get_if<TlsStream>(&s.mStream)) return teardown(role, *t, ec);
        teardown(role, std::get<beast::tcp_stream>(s.mStream).socket(), ec);
    }
    template <class Handler> friend void async_teardown(beast::role_type role, Stream& s, Handler&& handler) {
        using beast::websocket::async_teardown;
        if (auto* t = std::get_if<TlsStream>(&s.mStream)) return async_teardown(role, *t, std::forward<Handler>(handler));
        async_teardown(role, std::get<beast::tcp_stream>(s.mStream).socket(), std::forward<Handler>(handler));
    }

private:
    std::variant<beast::tcp_stream, TlsStream> mStream;
};

} // namespace dfb::net
