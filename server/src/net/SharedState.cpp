#include "net/SharedState.h"

#include "net/WebSocketSession.h"

#include "session/Lease.h"

#include <dfb/server/Engine.h>
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

void SharedState::addSession(std::shared_ptr<SessionHub> hub) {
    mFailed.erase(hub->id());
    hub->touch();
    mSessions[hub->id()] = std::move(hub);
}

void SharedState::setCatalog(std::shared_ptr<SessionCatalog> catalog, OpenPolicy policy) {
    mCatalog = std::move(catalog);
    mPolicy = policy;
}

void SharedState::stopOpening() { mOpener.join(); }

std::optional<std::string> SharedState::openNow(const SessionSpec& spec, int* exitCode) {
    auto result = mCatalog->open(spec, mIoc, mMetrics);
    if (auto* f = std::get_if<SessionCatalog::Failed>(&result)) *exitCode = f->exitCode;
    return install(spec, std::move(result));
}

std::optional<std::string> SharedState::install(const SessionSpec& spec, std::variant<SessionCatalog::Opened, SessionCatalog::Failed> result) {
    if (auto* f = std::get_if<SessionCatalog::Failed>(&result)) {
        std::fprintf(stderr, "dfb-server: session %s is not served here: %s\n", spec.name.c_str(), f->error.toString().c_str());
        if (f->error.code != ErrorCode::Moved) {
            FailedSession failed{spec.name, mCatalog->tokensFor(spec.name), redact(f->publicReason), std::nullopt};
            if (mPolicy.onRequest) failed.retryAt = std::chrono::steady_clock::now() + FAILED_RETRY_AFTER;
            addFailed(std::move(failed));
        }
        return std::nullopt;
    }
    auto& opened = std::get<SessionCatalog::Opened>(result);
    for (const std::string& dir : opened.privateDirectories) addPrivateDirectory(dir);
    std::shared_ptr<SessionHub> hub = std::move(opened.hub);
    hub->render().requestFrame();
    hub->startHousekeeping();
    addSession(hub);
    if (mDraining) closeSession(spec.name, "this node is shutting down: reconnect");
    return opened.banner;
}

void SharedState::acquire(const std::string& id, const std::string& token, Acquired done) {
    if (mDraining) return done(makeError(ErrorCode::Moved, "this node is shutting down: retry through the router"));
    const Error unauthorized = makeError(ErrorCode::Unauthorized, "the token does not open session '" + id + "'");
    if (auto hub = find(id)) {
        auto role = hub->roleFor(token);
        if (!role) return done(unauthorized);
        hub->touch();
        return done(std::make_pair(hub, *role));
    }
    if (auto it = mFailed.find(id); it != mFailed.end()) {
        const FailedSession& f = it->second;
        if (!f.tokens.roleFor(token)) return done(unauthorized);
        if (!f.retryAt || std::chrono::steady_clock::now() < *f.retryAt) {
            return done(makeError(ErrorCode::Unavailable, "session '" + id + "' is not available: " + f.reason));
        }
        mFailed.erase(it);
    }
    const auto spec = mCatalog ? mCatalog->find(id) : std::nullopt;
    if (!spec) return done(unauthorized);
    const auto role = mCatalog->tokensFor(id).roleFor(token);
    if (!role) return done(unauthorized);
    if (auto it = mHandedOver.find(id); it != mHandedOver.end()) {
        if (std::chrono::steady_clock::now() < it->second) {
            return done(makeError(ErrorCode::Moved, "session '" + id + "' was just handed over to another node; retry through the router"));
        }
        mHandedOver.erase(it);
    }
    if (!mOpening.count(id) && !makeRoom()) {
        return done(makeError(ErrorCode::Unavailable, "this node has its maximum of " + std::to_string(mPolicy.maxOpen) +
                                                          " sessions open, each with clients (--max-open-sessions); retry later"));
    }
    auto& waiters = mOpening[id];
    waiters.push_back([done = std::move(done), role = *role](Result<std::pair<std::shared_ptr<SessionHub>, protocol::Role>> r) {
        if (r) r.value().second = role;
        done(std::move(r));
    });
    if (waiters.size() > 1) return; // an open is under way
    asio::post(mOpener, [self = shared_from_this(), spec = *spec] {
        auto result = self->mCatalog->open(spec, self->mIoc, self->mMetrics);
        asio::post(self->mIoc, [self, spec, result = std::move(result)]() mutable {
            std::optional<Error> error;
            if (auto* f = std::get_if<SessionCatalog::Failed>(&result)) {
                error = f->error.code == ErrorCode::Moved
                            ? makeError(ErrorCode::Moved, self->redact(f->error.message))
                            : makeError(ErrorCode::Unavailable, "session '" + spec.name + "' is not available: " + self->redact(f->publicReason));
            }
            if (auto banner = self->install(spec, std::move(result))) {
                std::printf("%s (opened on request)\n", banner->c_str());
                std::fflush(stdout);
            }
            auto waiting = std::move(self->mOpening[spec.name]);
            self->mOpening.erase(spec.name);
            auto hub = self->find(spec.name);
            for (auto& w : waiting) {
                if (error) {
                    w(*error);
                } else if (hub) {
                    w(std::make_pair(hub, protocol::Role::Viewer));
                } else {
                    w(makeError(ErrorCode::Moved, "session '" + spec.name + "' was closed as it opened: retry"));
                }
            }
        });
    });
}

bool SharedState::makeRoom() {
    if (mSessions.size() + mOpening.size() < mPolicy.maxOpen) return true;
    std::string oldest;
    std::chrono::steady_clock::duration longest{};
    for (const auto& [id, hub] : mSessions) {
        if (hub->clientCount() > 0 || hub->finals().busy() || !hub->session().persistent()) continue;
        if (oldest.empty() || hub->idleFor() > longest) {
            oldest = id;
            longest = hub->idleFor();
        }
    }
    if (oldest.empty()) return false;
    closeSession(oldest, "closed to make room for another (--max-open-sessions " + std::to_string(mPolicy.maxOpen) + ")");
    return mSessions.size() + mOpening.size() < mPolicy.maxOpen;
}

nlohmann::json SharedState::sessionList(const std::string& token) {
    nlohmann::json list = nlohmann::json::array();
    const std::vector<SessionSpec> specs = mCatalog ? mCatalog->specs() : std::vector<SessionSpec>{};
    std::vector<std::string> ids;
    for (const auto& s : specs) ids.push_back(s.name);
    for (const auto& [id, hub] : mSessions) {
        if (std::find(ids.begin(), ids.end(), id) == ids.end()) ids.push_back(id);
    }
    for (const std::string& id : ids) {
        if (auto hub = find(id)) {
            auto role = hub->roleFor(token);
            if (!role) continue;
            const nlohmann::json& d = hub->session().description();
            list.push_back({{"id", id}, {"role", protocol::toString(*role)}, {"shot", d["shot"]}, {"width", d["width"]},
                            {"height", d["height"]}, {"rigVersion", hub->session().rigVersion()}, {"clients", hub->clientCount()},
                            {"state", "open"}});
        } else if (const FailedSession* f = failed(id)) {
            auto role = f->tokens.roleFor(token);
            if (role) list.push_back({{"id", id}, {"role", protocol::toString(*role)}, {"state", "failed"}, {"error", f->reason}});
        } else if (mCatalog) {
            auto role = mCatalog->tokensFor(id).roleFor(token);
            if (!role) continue;
            const auto spec = std::find_if(specs.begin(), specs.end(), [&](const SessionSpec& s) { return s.name == id; });
            nlohmann::json entry{{"id", id}, {"role", protocol::toString(*role)}, {"state", "closed"}};
            if (spec != specs.end()) entry["shot"] = std::filesystem::path(spec->shotPath).filename().string();
            if (const auto dir = mCatalog->stateDirOf(id); !dir.empty()) {
                if (std::string holder = Lease::holder(dir); !holder.empty()) {
                    entry["state"] = "elsewhere";
                    entry["node"] = holder;
                }
            }
            list.push_back(std::move(entry));
        }
    }
    return list;
}

void SharedState::startHousekeeping() {
    if (!mHousekeeping) mHousekeeping = std::make_unique<asio::steady_timer>(mIoc);
    mHousekeeping->expires_after(mPolicy.housekeepingInterval);
    mHousekeeping->async_wait([self = weak_from_this()](error_code ec) {
        auto s = self.lock();
        if (ec || !s) return;
        std::vector<std::pair<std::string, const char*>> closing;
        for (const auto& [id, hub] : s->mSessions) {
            const auto dir = s->mCatalog ? s->mCatalog->stateDirOf(id) : std::filesystem::path();
            std::error_code fsError;
            if (!dir.empty() && hub->openFor() >= s->mPolicy.handoffAfter && std::filesystem::exists(dir / Lease::HANDOFF_FILE_NAME, fsError)) {
                closing.emplace_back(id, "session moved to another node: reconnect");
                s->mHandedOver[id] = std::chrono::steady_clock::now() + s->mPolicy.handoffCooldown;
            } else if (s->mPolicy.onRequest && s->mPolicy.idleClose.count() > 0 && hub->session().persistent() && hub->clientCount() == 0 &&
                       hub->idleFor() >= s->mPolicy.idleClose && !hub->finals().busy()) {
                closing.emplace_back(id, "closed after being idle");
            }
        }
        for (const auto& [id, why] : closing) s->closeSession(id, why);
        s->startHousekeeping();
    });
}

void SharedState::closeSession(const std::string& id, const std::string& reason) {
    auto it = mSessions.find(id);
    if (it == mSessions.end()) return;
    std::shared_ptr<SessionHub> hub = std::move(it->second);
    mSessions.erase(it);
    hub->shutdown(reason);
    std::printf("dfb-server: session %s closed on this node: %s\n", id.c_str(), reason.c_str());
    std::fflush(stdout);
    std::erase_if(mClosing, [](const std::weak_ptr<SessionHub>& w) { return w.expired(); });
    mClosing.push_back(hub);
    // Its render thread and GPU memory go with the last reference: off the I/O thread when that
    // is this one (clients still closing hold theirs until they are gone).
    asio::post(mOpener, [hub = std::move(hub)]() mutable {
        const bool last = hub.use_count() == 1;
        hub.reset();
        if (last) releaseFreedMemory();
    });
}

void SharedState::drain(std::chrono::milliseconds grace, std::function<void()> done) {
    mDraining = true;
    std::vector<std::string> ids;
    for (const auto& [id, hub] : mSessions) ids.push_back(id);
    for (const std::string& id : ids) closeSession(id, "this node is shutting down: reconnect");
    const auto deadline = std::chrono::steady_clock::now() + grace;
    auto timer = std::make_shared<asio::steady_timer>(mIoc);
    auto poll = std::make_shared<std::function<void()>>();
    *poll = [self = shared_from_this(), timer, poll, deadline, done = std::move(done)] {
        std::erase_if(self->mClosing, [](const std::weak_ptr<SessionHub>& w) {
            auto h = w.lock();
            return !h || h->clientCount() == 0;
        });
        if (self->mClosing.empty() || std::chrono::steady_clock::now() >= deadline) {
            *poll = nullptr; // breaks the cycle
            return done();
        }
        timer->expires_after(std::chrono::milliseconds(20));
        timer->async_wait([poll](error_code) {
            if (*poll) (*poll)();
        });
    };
    (*poll)();
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

void SessionHub::shutdown(const std::string& reason) {
    if (mClosed) return;
    mClosed = true;
    mSession->close();
    mLease.reset();
    mHousekeeping.cancel();
    if (mFinals->busy()) (void)mFinals->cancel();
    std::vector<std::weak_ptr<WebSocketSession>> targets;
    for (WebSocketSession* c : mClients) targets.push_back(c->weak_from_this());
    for (auto& w : targets) {
        if (auto s = w.lock()) s->closeWith(websocket::close_code::service_restart, reason);
    }
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
