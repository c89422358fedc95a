#include "net/SharedState.h"

#include "net/WebSocketSession.h"

#include <algorithm>
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

std::shared_ptr<SessionHub> SharedState::find(const std::string& id) const {
    auto it = mSessions.find(id);
    return it == mSessions.end() ? nullptr : it->second;
}

namespace {
// Token comparison whose time does not depend on where the strings differ.
bool sameToken(std::string_view a, std::string_view b) {
    unsigned diff = a.size() == b.size() ? 0u : 1u;
    for (size_t i = 0; i < a.size(); ++i) diff |= unsigned(uint8_t(a[i]) ^ uint8_t(i < b.size() ? b[i] : 0));
    return diff == 0 && !a.empty();
}
} // namespace

std::optional<protocol::Role> SessionHub::roleFor(std::string_view token) const {
    if (sameToken(token, mTokens.editor)) return protocol::Role::Editor;
    if (sameToken(token, mTokens.viewer)) return protocol::Role::Viewer;
    return std::nullopt;
}

void SessionHub::join(WebSocketSession* ws) { mClients.insert(ws); }
void SessionHub::leave(WebSocketSession* ws) { mClients.erase(ws); }

std::vector<protocol::ClientInfo> SessionHub::clients() const {
    std::vector<protocol::ClientInfo> out;
    for (const WebSocketSession* c : mClients) out.push_back(c->info());
    std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
    return out;
}

void SessionHub::broadcastText(const std::string& message, const WebSocketSession* except) {
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

void SessionHub::published(const ChangeOutcome& outcome, const WebSocketSession* except) {
    mMetrics.changeAccepted(id(), outcome.info.rigVersion);
    broadcastText(protocol::encodeChange(outcome.info), except);
    mRender->requestFrame();
}

void SessionHub::broadcastPresence() { broadcastText(protocol::encodePresence(clients()), nullptr); }

void SessionHub::onNewImage(uint64_t serial) {
    asio::post(mIoc, [self = shared_from_this(), serial] {
        std::vector<std::weak_ptr<WebSocketSession>> targets;
        for (WebSocketSession* c : self->mClients) targets.push_back(c->weak_from_this());
        for (auto& w : targets) {
            if (auto s = w.lock()) s->frameAvailable(serial);
        }
    });
}

} // namespace dfb::net
