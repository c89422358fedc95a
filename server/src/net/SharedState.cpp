#include "net/SharedState.h"

#include "net/WebSocketSession.h"

#include <dfb/server/GltfExport.h>

#include <algorithm>
#include <boost/asio/ssl/error.hpp>

#include <cstdio>
#include <filesystem>
#include <vector>

namespace dfb::net {

bool isNormalClose(error_code ec) {
    // A client going away is not an error: a close handshake, EOF, a reset, a socket already shut
    // down (ENOTCONN after the peer's close), or a TLS peer that closes without close_notify
    // (browsers do; "stream truncated").
    return ec == asio::error::operation_aborted || ec == websocket::error::closed || ec == asio::error::eof ||
           ec == beast::error::timeout || ec == asio::error::connection_reset || ec == asio::error::broken_pipe ||
           ec == asio::error::not_connected || ec == asio::ssl::error::stream_truncated || ec == http::error::end_of_stream;
}

void fail(error_code ec, const char* what) {
    if (isNormalClose(ec)) return;
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

std::optional<protocol::Role> SessionTokens::roleFor(std::string_view token) const {
    if (sameToken(token, editor)) return protocol::Role::Editor;
    if (sameToken(token, viewer)) return protocol::Role::Viewer;
    return std::nullopt;
}

const FailedSession* SharedState::failed(const std::string& id) const {
    auto it = mFailed.find(id);
    return it == mFailed.end() ? nullptr : &it->second;
}

std::shared_ptr<void> SharedState::admit(const asio::ip::address& from) {
    std::lock_guard lock(mConnectionsMutex);
    size_t& n = mConnections[from];
    if (n >= mLimits.maxConnectionsPerAddress) {
        if (n == 0) mConnections.erase(from);
        return nullptr;
    }
    ++n;
    // The slot gives the connection back when its last owner (the HTTP or WebSocket session) ends.
    struct Slot {
        Slot(std::shared_ptr<SharedState> s, asio::ip::address a) : state(std::move(s)), from(a) {}
        Slot(const Slot&) = delete;
        Slot& operator=(const Slot&) = delete;
        std::shared_ptr<SharedState> state;
        asio::ip::address from;
        ~Slot() {
            state->mMetrics.connectionsOpen(-1);
            std::lock_guard released(state->mConnectionsMutex);
            auto it = state->mConnections.find(from);
            if (it != state->mConnections.end() && --it->second == 0) state->mConnections.erase(it);
        }
    };
    mMetrics.connectionsOpen(1);
    return std::make_shared<Slot>(shared_from_this(), from);
}

std::string SharedState::redact(std::string message) const {
    for (const std::string& dir : mPrivateDirs) {
        for (size_t at; !dir.empty() && (at = message.find(dir)) != std::string::npos;) message.replace(at, dir.size(), "");
    }
    return message;
}

void SharedState::addPrivateDirectory(const std::string& dir) {
    if (dir.empty() || dir == "." || dir == "/") return;
    std::error_code ec;
    const auto abs = std::filesystem::absolute(dir, ec);
    for (std::string d : {dir, ec ? std::string() : abs.string()}) {
        if (d.empty()) continue;
        if (d.back() != '/') d += '/';
        if (std::find(mPrivateDirs.begin(), mPrivateDirs.end(), d) == mPrivateDirs.end()) mPrivateDirs.push_back(d);
    }
    // Longest first, so that a folder inside another is removed whole.
    std::sort(mPrivateDirs.begin(), mPrivateDirs.end(), [](const auto& a, const auto& b) { return a.size() > b.size(); });
}

void SessionHub::startHousekeeping() {
    mHousekeeping.expires_after(Session::RIG_SAVE_INTERVAL);
    mHousekeeping.async_wait([self = weak_from_this()](error_code ec) {
        auto s = self.lock();
        if (ec || !s) return;
        s->mSession->flushSavedRig();
        s->startHousekeeping();
    });
}

void SessionHub::join(WebSocketSession* ws) { mClients.insert(ws); }
void SessionHub::leave(WebSocketSession* ws) { mClients.erase(ws); }

std::vector<protocol::ClientInfo> SessionHub::clients() const {
    std::vector<protocol::ClientInfo> out;
    for (const WebSocketSession* c : mClients) out.push_back(c->info());
    std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
    return out;
}

void SessionHub::published(const ChangeOutcome& outcome, const WebSocketSession* except) {
    mMetrics.changeAccepted(id(), outcome.info.rigVersion);
    // Coalesced by each client with the others of its interval; encoded once, shared, not copied.
    auto change = std::make_shared<const BroadcastChange>(
        BroadcastChange{outcome.info, std::make_shared<const std::string>(protocol::encodeChange(outcome.info))});
    std::vector<std::weak_ptr<WebSocketSession>> targets;
    for (WebSocketSession* c : mClients) {
        if (c != except) targets.push_back(c->weak_from_this());
    }
    for (auto& w : targets) {
        if (auto s = w.lock()) s->changeAvailable(change);
    }
    mRender->requestFrame();
}

void SessionHub::broadcastText(std::shared_ptr<const std::string> message) {
    std::vector<std::weak_ptr<WebSocketSession>> targets;
    for (WebSocketSession* c : mClients) targets.push_back(c->weak_from_this());
    for (auto& w : targets) {
        if (auto s = w.lock()) s->sendText(message);
    }
}

void SessionHub::makeFinalRenders() {
    // The hub outlives its final renders (it owns them): `this` in the callbacks stays valid.
    auto exporter = [this](const Rig& rig, std::function<void(Result<std::string>)> done) {
        const std::string scene = mSession->scenePath();
        mRender->requestPickerJob([scene, rig, done = std::move(done)](const Picker&, const DeepBuffer&) {
            done(scene.empty() ? Result<std::string>(makeError(ErrorCode::FileNotFound, "the session has no scene file"))
                               : exportGltf(scene, rig));
        });
    };
    auto notify = [this](const nlohmann::json& message) { broadcastText(std::make_shared<const std::string>(message.dump())); };
    mFinals = std::make_unique<FinalRenders>(mIoc, *mShot, exporter, notify);
}

void SessionHub::libraryChanged() {
    nlohmann::json message = mLibrary->list();
    message["type"] = "library";
    broadcastText(std::make_shared<const std::string>(message.dump()));
}

void SessionHub::annotationsChanged() {
    const nlohmann::json message{{"type", "annotations"}, {"annotations", mAnnotations->list()}};
    broadcastText(std::make_shared<const std::string>(protocol::dump(message)));
}

void SessionHub::broadcastPresence() {
    std::vector<std::weak_ptr<WebSocketSession>> targets;
    for (WebSocketSession* c : mClients) targets.push_back(c->weak_from_this());
    for (auto& w : targets) {
        if (auto s = w.lock()) s->presenceChanged();
    }
}

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
