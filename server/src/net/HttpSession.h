#pragma once
// One HTTP connection: serves the page, the rig and frames, and hands WebSocket upgrades over to
// a WebSocketSession. Requests on one connection are answered in order, one at a time.

#include "net/Beast.h"
#include "net/SharedState.h"

#include <dfb/server/Outputs.h>

#include <memory>
#include <optional>

namespace dfb::net {

class HttpSession : public std::enable_shared_from_this<HttpSession> {
public:
    HttpSession(tcp::socket&& socket, std::shared_ptr<SharedState> state);
    void run();

private:
    void doRead();
    void onRead(error_code ec, size_t bytes);
    void handle(http::request<http::string_body>&& req);
    void send(http::response<http::string_body>&& res);
    void onWrite(bool close, error_code ec, size_t bytes);
    void sendFrame(OutputRequest request, unsigned version, bool keepAlive);

    beast::tcp_stream mStream;
    beast::flat_buffer mBuffer;
    std::shared_ptr<SharedState> mState;
    std::optional<http::request_parser<http::string_body>> mParser;
    std::shared_ptr<void> mResponse; // keeps the response alive during async_write
};

} // namespace dfb::net
