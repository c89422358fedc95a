#pragma once
// State shared by every connection of the server (Beast chat-multi's shared_state): the open
// sessions by id, the catalog of those that can be opened, and the metrics. The maps are touched
// only from the I/O thread (the server runs one), so lookups need no lock; sessions are opened on
// a thread of their own and handed back to the I/O thread.

#include "net/Beast.h"
#include "net/SessionCatalog.h"
#include "net/SessionHub.h"
#include "session/Metrics.h"

#include <boost/asio/thread_pool.hpp>

#include <chrono>
#include <functional>
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
    /// Sessions opened on request are tried again after this time (a shot re-baked, a journal
    /// repaired); at-start ones are not.
    std::optional<std::chrono::steady_clock::time_point> retryAt;
};

/// When sessions are opened and closed (docs/deployment.md).
struct OpenPolicy {
    /// Open each session on its first request (a fleet's nodes) instead of all at start.
    bool onRequest = false;
    /// A session opened on request with no client and no request for this long is closed (its
    /// GPU objects and memory freed, its lease released; the journal stays). 0: never.
    std::chrono::seconds idleClose{600};
    /// A session is handed over to the node that asks (Lease::HANDOFF_FILE_NAME) only after it
    /// has been open this long here, so that a client reaching two nodes cannot bounce it.
    std::chrono::seconds handoffAfter{2};
    /// A session handed over is not reopened here for this long (this node answers `moved`), so
    /// that the node that asked gets it even while requests still reach this one.
    std::chrono::seconds handoffCooldown{5};
    /// Most sessions open at once on this node (--max-open-sessions): opening one more first
    /// closes the session idle longest that has no client; when every open session has clients
    /// the request is refused (503 unavailable, naming the limit).
    size_t maxOpen = 64;
    /// How often idle sessions and handoff requests are looked for.
    std::chrono::milliseconds housekeepingInterval{500};
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
    void addSession(std::shared_ptr<SessionHub> hub);
    /// Null when there is no such session open.
    std::shared_ptr<SessionHub> find(const std::string& id) const;
    const std::map<std::string, std::shared_ptr<SessionHub>>& sessions() const { return mSessions; }

    /// The sessions this server can open, and when it opens and closes them.
    void setCatalog(std::shared_ptr<SessionCatalog> catalog, OpenPolicy policy);
    SessionCatalog& catalog() { return *mCatalog; }
    const OpenPolicy& policy() const { return mPolicy; }
    /// The session `id` for a request carrying `token`, opened first if it is not open (on the
    /// opener thread; `done` runs on the I/O thread). Errors: Unauthorized (no such session or a
    /// token that does not open it: the same answer), Unavailable (it failed to open), Moved
    /// (another node holds it; a handoff is asked for). I/O thread.
    using Acquired = std::function<void(Result<std::pair<std::shared_ptr<SessionHub>, protocol::Role>>)>;
    void acquire(const std::string& id, const std::string& token, Acquired done);
    /// GET /v1/sessions: every session of the catalog the token opens, open here or not.
    nlohmann::json sessionList(const std::string& token);
    /// Starts the periodic idle close and handoff check. I/O thread.
    void startHousekeeping();
    /// Closes session `id` here (SessionHub::shutdown) and forgets it. I/O thread.
    void closeSession(const std::string& id, const std::string& reason);
    /// SIGTERM: not ready any more (GET /readyz 503), every session closed, then `done` once their
    /// clients are gone (or after at most `grace`). I/O thread.
    void drain(std::chrono::milliseconds grace, std::function<void()> done);
    bool draining() const { return mDraining; }
    /// Opens `spec` now, on this thread (at start): its banner line, or nothing when it failed
    /// (then it is listed as failed, and Moved sessions not at all) and `exitCode` says why.
    std::optional<std::string> openNow(const SessionSpec& spec, int* exitCode);
    /// Waits for the opener thread's jobs (before the server exits).
    void stopOpening();
    /// Client ids are unique across sessions and never reused while the server runs.
    uint64_t nextClientId() { return ++mLastClientId; }

private:
    asio::io_context& mIoc;
    Metrics mMetrics;
    std::map<std::string, std::shared_ptr<SessionHub>> mSessions;
    std::map<std::string, FailedSession> mFailed;
    uint64_t mLastClientId = 0;
    ServerLimits mLimits;
    std::shared_ptr<SessionCatalog> mCatalog;
    OpenPolicy mPolicy;
    // Opens (and closes) run here one at a time, in order: a close's lease is gone before the
    // next open of that session takes it.
    boost::asio::thread_pool mOpener{1};
    std::map<std::string, std::vector<Acquired>> mOpening; // opens in progress, with their waiters
    std::unique_ptr<asio::steady_timer> mHousekeeping;
    bool mDraining = false;
    std::vector<std::weak_ptr<SessionHub>> mClosing; // closed sessions whose clients may still be leaving
    std::map<std::string, std::chrono::steady_clock::time_point> mHandedOver; // until when each is not reopened here
    // A session opened on request that failed is tried again after this.
    static constexpr std::chrono::seconds FAILED_RETRY_AFTER{5};
    std::optional<std::string> install(const SessionSpec& spec, std::variant<SessionCatalog::Opened, SessionCatalog::Failed> result);
    // Room for one more open session under OpenPolicy::maxOpen: true when there is (an idle one
    // closed if need be).
    bool makeRoom();
    std::vector<std::string> mPrivateDirs;
    std::mutex mConnectionsMutex;
    std::map<asio::ip::address, size_t> mConnections;
};

} // namespace dfb::net
