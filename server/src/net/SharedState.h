#pragma once
// State shared by every connection of the server (Beast chat-multi's shared_state): the sessions
// by id and the metrics. Built before the listener starts and not changed after, so lookups need
// no lock; the hubs themselves are touched only from the I/O thread, except where noted.

#include "net/Beast.h"
#include "net/SessionHub.h"
#include "session/Metrics.h"

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace dfb::net {

/// The server's limits on connections (docs/operations.md "Limits"; each has a flag of
/// dfb-server). Limits on a rig's contents are protocol::RigLimits.
struct ServerLimits {
    /// WebSocket clients of one session (--max-clients-per-session); one more is accepted and
    /// closed at once with code 1013 (try again later) and a reason naming the limit.
    size_t maxClientsPerSession = 128;
    /// Open TCP connections from one IP address (--max-connections-per-address); a request on
    /// one more is answered 503 with Retry-After and the connection closed.
    size_t maxConnectionsPerAddress = 256;
    /// GET /metrics labels its series with session names; false sums them without labels
    /// (--metrics-session-names=false), for a metrics endpoint others can read.
    bool metricsSessionNames = true;
};

/// A session that could not be opened (its journal is damaged, its shot unreadable): its tokens
/// still open it, and every request gets `reason` (503, "unavailable") while the others serve.
struct FailedSession {
    std::string id;
    SessionTokens tokens;
    std::string reason; ///< for clients: no server paths
};

class SharedState : public std::enable_shared_from_this<SharedState> {
public:
    explicit SharedState(asio::io_context& ioc) : mIoc(ioc) {}

    ServerLimits& limits() { return mLimits; }
    void addFailed(FailedSession f) { mFailed[f.id] = std::move(f); }
    /// Null when `id` did not fail.
    const FailedSession* failed(const std::string& id) const;
    const std::map<std::string, FailedSession>& failedSessions() const { return mFailed; }
    /// A connection slot for a peer at `from`: held for the connection's life; null when that
    /// address already has ServerLimits::maxConnectionsPerAddress. Any thread.
    std::shared_ptr<void> admit(const asio::ip::address& from);
    /// Folders of the server (assets, state, shots) whose names clients need not see: error
    /// messages sent to clients go through redact(), which removes them.
    void addPrivateDirectory(const std::string& dir);
    std::string redact(std::string message) const;

    asio::io_context& ioc() { return mIoc; }
    Metrics& metrics() { return mMetrics; }
    void addSession(std::shared_ptr<SessionHub> hub) { mSessions[hub->id()] = std::move(hub); }
    /// Null when there is no such session.
    std::shared_ptr<SessionHub> find(const std::string& id) const;
    const std::map<std::string, std::shared_ptr<SessionHub>>& sessions() const { return mSessions; }
    /// Client ids are unique across sessions and never reused while the server runs.
    uint64_t nextClientId() { return ++mLastClientId; }

private:
    asio::io_context& mIoc;
    Metrics mMetrics;
    std::map<std::string, std::shared_ptr<SessionHub>> mSessions;
    std::map<std::string, FailedSession> mFailed;
    uint64_t mLastClientId = 0;
    ServerLimits mLimits;
    std::vector<std::string> mPrivateDirs;
    std::mutex mConnectionsMutex;
    std::map<asio::ip::address, size_t> mConnections;
};

} // namespace dfb::net
