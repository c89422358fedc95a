#include "net/Listener.h"

#include "net/HttpSession.h"

namespace dfb::net {

Status Listener::open(const tcp::endpoint& endpoint) {
    error_code ec;
    auto failWith = [&](const char* what) {
        return makeError(ErrorCode::Network, std::string(what) + " " + endpoint.address().to_string() + ":" +
                                                 std::to_string(endpoint.port()) + ": " + ec.message());
    };
    mAcceptor.open(endpoint.protocol(), ec);
    if (ec) return failWith("cannot open a socket for");
    mAcceptor.set_option(asio::socket_base::reuse_address(true), ec);
    mAcceptor.bind(endpoint, ec);
    if (ec) return failWith("cannot bind");
    mAcceptor.listen(asio::socket_base::max_listen_connections, ec);
    if (ec) return failWith("cannot listen on");
    return okStatus();
}

void Listener::doAccept() {
    mAcceptor.async_accept(asio::make_strand(mIoc), beast::bind_front_handler(&Listener::onAccept, shared_from_this()));
}

void Listener::onAccept(error_code ec, tcp::socket socket) {
    if (ec) {
        fail(ec, "accept");
    } else {
        // Small messages (acks, changes, frame headers) must not wait for Nagle's algorithm to
        // meet the peer's delayed ACK: that adds ~40 ms to an edit-to-frame round trip.
        error_code ignored;
        socket.set_option(tcp::no_delay(true), ignored);
        error_code peerError;
        const auto peer = socket.remote_endpoint(peerError);
        std::shared_ptr<void> slot = peerError ? nullptr : mState->admit(peer.address());
        auto stream = mTls ? Stream(std::move(socket), *mTls) : Stream(std::move(socket));
        std::make_shared<HttpSession>(std::move(stream), mState, std::move(slot))->run();
    }
    if (mAcceptor.is_open()) doAccept();
}

} // namespace dfb::net
