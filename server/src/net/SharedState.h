#pragma once
// State shared by every connection of the server (Beast chat-multi's shared_state): the sessions
// by id and the metrics. Built before the listener starts and not changed after, so lookups need
// no lock; the hubs themselves are touched only from the I/O thread, except where noted.

#include "net/Beast.h"
#include "net/SessionHub.h"
#include "session/Metrics.h"

#include <map>
#include <memory>
#include <string>

namespace dfb::net {

class SharedState {
public:
    explicit SharedState(asio::io_context& ioc) : mIoc(ioc) {}

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
    uint64_t mLastClientId = 0;
};

} // namespace dfb::net
