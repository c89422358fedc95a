#include "net/SharedState.h"

#include "net/WebSocketSession.h"

#include <cstdio>
#include <vector>

namespace dfb::net {

void fail(error_code ec, const char* what) {
    if (ec == asio::error::operation_aborted || ec == websocket::error::closed || ec == asio::error::eof ||
        ec == beast::error::timeout || ec == asio::error::connection_reset || ec == asio::error::broken_pipe) {
        return;
    }
    std::fprintf(stderr, "dfb-server: %s: %s\n", what, ec.message().c_str());
}

void SharedState::join(WebSocketSession* ws) { mClients.insert(ws); }
void SharedState::leave(WebSocketSession* ws) { mClients.erase(ws); }

void SharedState::broadcastText(const std::string& message, const WebSocketSession* except) {
    auto shared = std::make_shared<const std::string>(message);
    // Hold strong references while sending: a send may close (and remove) a session.
    std::vector<std::weak_ptr<WebSocketSession>> targets;
    for (WebSocketSession* c : mClients) {
        if (c != except) targets.push_back(c->weak_from_this());
    }
    for (auto& w : targets) {
        if (auto s = w.lock()) s->sendText(shared);
    }
}

void SharedState::publishFrame(std::shared_ptr<const EncodedFrame> frame) {
    asio::post(mIoc, [self = shared_from_this(), frame] {
        std::vector<std::weak_ptr<WebSocketSession>> targets;
        for (WebSocketSession* c : self->mClients) targets.push_back(c->weak_from_this());
        for (auto& w : targets) {
            if (auto s = w.lock()) s->sendFrame(frame);
        }
    });
}

} // namespace dfb::net
