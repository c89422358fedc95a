#pragma once
// Beast/Asio names used across the network code (Beast's chat-multi example layout).
// Boost 1.74 asio/awaitable.hpp uses std::exchange without including <utility> (C++20, GCC 12).
#include <utility>

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

namespace dfb::net {
namespace beast = boost::beast;
namespace http = boost::beast::http;
namespace websocket = boost::beast::websocket;
namespace asio = boost::asio;
using tcp = boost::asio::ip::tcp;
using error_code = boost::beast::error_code;

/// Whether `ec` only means that the peer closed or the operation was cancelled.
bool isNormalClose(error_code ec);
/// Reports a failed async operation on stderr, ignoring isNormalClose ones.
void fail(error_code ec, const char* what);
} // namespace dfb::net
