#pragma once
// Server counters for GET /metrics (Prometheus text exposition format 0.0.4). Thread-safe: the
// network thread counts bytes and clients, the render threads count frames and latencies.

#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace dfb {

class Metrics {
public:
    using Clock = std::chrono::steady_clock;

    /// Upper bounds of the edit-to-frame latency histogram, seconds (the relight loop aims at
    /// tens of milliseconds; llvmpipe at 960x540 takes 50-500 ms; the tail catches stalls).
    static constexpr double LATENCY_BUCKETS[] = {0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0};

    /// A change of `session` reached version `version` at `when`.
    void changeAccepted(const std::string& session, uint64_t version, Clock::time_point when = Clock::now());
    /// A frame of `session` showing `version` is rendered: observes the latency of every accepted
    /// change up to that version not yet shown.
    void frameRendered(const std::string& session, uint64_t version, Clock::time_point when = Clock::now());
    void frameEncoded(const std::string& session);
    void frameSent(const std::string& session, size_t bytes);
    void bytesSent(const std::string& session, size_t bytes);
    void clientJoined(const std::string& session, const std::string& role, int delta);
    void editRefused(const std::string& session);
    /// A connection or WebSocket client was refused for a limit (per address, per session).
    void connectionRefused();
    /// Open TCP connections (HTTP and WebSocket) changed by `delta`.
    void connectionsOpen(int delta);

    /// The Prometheus text of every metric; without `sessionNames` the per-session series are
    /// summed into one series without a session label (names are not shown to whoever can read
    /// the endpoint).
    std::string text(bool sessionNames = true) const;

private:
    struct PerSession {
        uint64_t renderedVersion = 0;
        uint64_t framesRendered = 0, framesEncoded = 0, framesSent = 0, bytesSent = 0, changes = 0, refused = 0;
        std::map<std::string, int64_t> clients; // by role
        std::map<uint64_t, Clock::time_point> pending; // accepted versions not yet on a frame
    };
    void observe(double seconds); // with mMutex held
    mutable std::mutex mMutex;
    std::map<std::string, PerSession> mSessions;
    std::vector<uint64_t> mBuckets = std::vector<uint64_t>(std::size(LATENCY_BUCKETS) + 1, 0);
    double mLatencySum = 0;
    uint64_t mLatencyCount = 0;
    uint64_t mConnectionsRefused = 0;
    int64_t mConnectionsOpen = 0;
};

} // namespace dfb
