#pragma once
// One HTTP connection: serves the page, health and metrics, the v1 session resources for scripts
// (docs/protocol.md "HTTP"), and hands WebSocket upgrades of /v1/sessions/ID/ws over to a
// WebSocketSession once the token is checked. Requests on one connection are answered in order,
// one at a time.

#include "net/Beast.h"
#include "net/SharedState.h"
#include "net/Stream.h"

#include <memory>
#include <optional>

namespace dfb::net {

class HttpSession : public std::enable_shared_from_this<HttpSession> {
public:
    /// `slot`: the connection's place under the per-address limit (SharedState::admit); null
    /// when the address is over it, and then the first request is answered 503 and the
    /// connection closed.
    /// `stream`: plain or TLS (not yet handshaken).
    HttpSession(Stream&& stream, std::shared_ptr<SharedState> state, std::shared_ptr<void> slot);
    void run();

private:
    using Request = http::request<http::string_body>;
    using Response = http::response<http::string_body>;

    void onHandshake(error_code ec);
    void doRead();
    // Ends the connection after the last response: TLS close_notify when on TLS, then TCP.
    void shutdown();
    void onRead(error_code ec, size_t bytes);
    void handle(Request&& req);
    void handleSession(const Request& req, const std::shared_ptr<SessionHub>& hub, protocol::Role role,
                       const std::string& resource, const std::string& query);
    void send(Response&& res);
    // A request for a session that SharedState::acquire refused: a token that does not open it or
    // no such session (the same answer, so that session names cannot be probed for), a session
    // that failed to open (503 with its reason), or one open on another node (503 moved).
    void sendRefusal(const Request& req, const Error& e);
    void onWrite(bool close, error_code ec, size_t bytes);

    Stream mStream;
    beast::flat_buffer mBuffer;
    std::shared_ptr<SharedState> mState;
    std::optional<http::request_parser<http::string_body>> mParser;
    std::shared_ptr<void> mResponse; // keeps the response alive during async_write
    std::shared_ptr<void> mSlot;
};

} // namespace dfb::net
