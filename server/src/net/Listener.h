#pragma once
// Accepts TCP connections and starts an HttpSession for each.

#include "net/Beast.h"
#include "net/SharedState.h"
#include "net/Stream.h"

#include <memory>

namespace dfb::net {

class Listener : public std::enable_shared_from_this<Listener> {
public:
    /// With `tls`, every connection speaks TLS (HTTPS and WSS); the context outlives the listener.
    Listener(asio::io_context& ioc, std::shared_ptr<SharedState> state, asio::ssl::context* tls = nullptr)
        : mIoc(ioc), mAcceptor(ioc), mState(std::move(state)), mTls(tls) {}
    /// Binds and listens; port 0 picks a free port (see port()).
    Status open(const tcp::endpoint& endpoint);
    unsigned short port() const { return mAcceptor.local_endpoint().port(); }
    void run() { doAccept(); }
    /// Stops accepting (a draining node): new connections are refused by the kernel.
    void close() {
        error_code ignored;
        mAcceptor.close(ignored);
    }

private:
    void doAccept();
    void onAccept(error_code ec, tcp::socket socket);

    asio::io_context& mIoc;
    tcp::acceptor mAcceptor;
    std::shared_ptr<SharedState> mState;
    asio::ssl::context* mTls;
};

} // namespace dfb::net
