#include "session/Metrics.h"

#include <algorithm>
#include <iterator>
#include <sstream>

namespace dfb {

void Metrics::changeAccepted(const std::string& session, uint64_t version, Clock::time_point when) {
    std::lock_guard lock(mMutex);
    auto& s = mSessions[session];
    ++s.changes;
    if (version <= s.renderedVersion) {
        // The render thread was faster than this bookkeeping: the frame is already there.
        observe(0.0);
        return;
    }
    s.pending.emplace(version, when);
    // A session whose frames fail keeps no unbounded backlog.
    while (s.pending.size() > 10000) s.pending.erase(s.pending.begin());
}

void Metrics::frameRendered(const std::string& session, uint64_t version, Clock::time_point when) {
    std::lock_guard lock(mMutex);
    auto& s = mSessions[session];
    ++s.framesRendered;
    s.renderedVersion = std::max(s.renderedVersion, version);
    for (auto it = s.pending.begin(); it != s.pending.end() && it->first <= version;) {
        observe(std::chrono::duration<double>(when - it->second).count());
        it = s.pending.erase(it);
    }
}

void Metrics::observe(double seconds) {
    size_t b = 0;
    while (b < std::size(LATENCY_BUCKETS) && seconds > LATENCY_BUCKETS[b]) ++b;
    ++mBuckets[b];
    mLatencySum += seconds;
    ++mLatencyCount;
}

void Metrics::frameEncoded(const std::string& session) {
    std::lock_guard lock(mMutex);
    ++mSessions[session].framesEncoded;
}

void Metrics::frameSent(const std::string& session, size_t bytes) {
    std::lock_guard lock(mMutex);
    auto& s = mSessions[session];
    ++s.framesSent;
    s.bytesSent += bytes;
}

void Metrics::bytesSent(const std::string& session, size_t bytes) {
    std::lock_guard lock(mMutex);
    mSessions[session].bytesSent += bytes;
}

void Metrics::clientJoined(const std::string& session, const std::string& role, int delta) {
    std::lock_guard lock(mMutex);
    mSessions[session].clients[role] += delta;
}

void Metrics::editRefused(const std::string& session) {
    std::lock_guard lock(mMutex);
    ++mSessions[session].refused;
}

void Metrics::connectionRefused() {
    std::lock_guard lock(mMutex);
    ++mConnectionsRefused;
}

void Metrics::connectionsOpen(int delta) {
    std::lock_guard lock(mMutex);
    mConnectionsOpen += delta;
}

std::string Metrics::text(bool sessionNames) const {
    std::lock_guard lock(mMutex);
    std::ostringstream o;
    auto family = [&](const char* name, const char* type, const char* help, auto value) {
        o << "# HELP " << name << " " << help << "\n# TYPE " << name << " " << type << "\n";
        if (!sessionNames) {
            uint64_t sum = 0;
            for (const auto& [id, s] : mSessions) sum += uint64_t(value(s));
            o << name << " " << sum << "\n";
            return;
        }
        for (const auto& [id, s] : mSessions) o << name << "{session=\"" << id << "\"} " << value(s) << "\n";
    };
    family("dfb_frames_rendered_total", "counter", "Frames rendered (one per new rig version shown).",
           [](const PerSession& s) { return s.framesRendered; });
    family("dfb_frames_encoded_total", "counter", "Frame encodings (one per version and distinct view settings).",
           [](const PerSession& s) { return s.framesEncoded; });
    family("dfb_frames_sent_total", "counter", "Frames written to WebSocket clients and HTTP frame requests.",
           [](const PerSession& s) { return s.framesSent; });
    family("dfb_bytes_sent_total", "counter", "Bytes of frames and messages written to clients.",
           [](const PerSession& s) { return s.bytesSent; });
    family("dfb_changes_total", "counter", "Accepted rig changes (edits, time, undo, redo, replace).",
           [](const PerSession& s) { return s.changes; });
    family("dfb_changes_refused_total", "counter", "Refused rig changes (invalid, forbidden, conflicting).",
           [](const PerSession& s) { return s.refused; });
    o << "# HELP dfb_clients Connected WebSocket clients.\n# TYPE dfb_clients gauge\n";
    for (const char* role : {"editor", "viewer"}) {
        int64_t sum = 0;
        for (const auto& [id, s] : mSessions) {
            auto it = s.clients.find(role);
            const int64_t n = it == s.clients.end() ? 0 : it->second;
            sum += n;
            if (sessionNames) o << "dfb_clients{session=\"" << id << "\",role=\"" << role << "\"} " << n << "\n";
        }
        if (!sessionNames) o << "dfb_clients{role=\"" << role << "\"} " << sum << "\n";
    }
    o << "# HELP dfb_connections_refused_total Connections and WebSocket clients refused for a limit.\n"
         "# TYPE dfb_connections_refused_total counter\n"
         "dfb_connections_refused_total " << mConnectionsRefused << "\n"
      << "# HELP dfb_connections_open Open HTTP and WebSocket connections (each holds a slot of the per-address limit).\n"
         "# TYPE dfb_connections_open gauge\n"
         "dfb_connections_open " << mConnectionsOpen << "\n";
    o << "# HELP dfb_edit_to_frame_seconds Time from an accepted change to the first rendered frame showing it (encoding is per client view, after).\n"
         "# TYPE dfb_edit_to_frame_seconds histogram\n";
    uint64_t cumulative = 0;
    for (size_t b = 0; b < std::size(LATENCY_BUCKETS); ++b) {
        cumulative += mBuckets[b];
        o << "dfb_edit_to_frame_seconds_bucket{le=\"" << LATENCY_BUCKETS[b] << "\"} " << cumulative << "\n";
    }
    cumulative += mBuckets.back();
    o << "dfb_edit_to_frame_seconds_bucket{le=\"+Inf\"} " << cumulative << "\n";
    o << "dfb_edit_to_frame_seconds_sum " << mLatencySum << "\n";
    o << "dfb_edit_to_frame_seconds_count " << mLatencyCount << "\n";
    return o.str();
}

} // namespace dfb
