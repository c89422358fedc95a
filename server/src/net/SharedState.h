#pragma once
// State shared by every connection of the server (Beast chat-multi's shared_state): the session,
// the render service and the set of connected WebSocket clients. Touched only from the I/O
// thread, except where noted.

#include "net/Beast.h"
#include "session/RenderService.h"
#include "session/Session.h"

#include <memory>
#include <set>
#include <string>

namespace dfb::net {

class WebSocketSession;

class SharedState : public std::enable_shared_from_this<SharedState> {
public:
    SharedState(asio::io_context& ioc, Session& session) : mIoc(ioc), mSession(session) {}

    void setRenderService(RenderService* render) { mRender = render; }
    Session& session() { return mSession; }
    RenderService& render() { return *mRender; }
    asio::io_context& ioc() { return mIoc; }

    void join(WebSocketSession* ws);
    void leave(WebSocketSession* ws);
    uint64_t nextClientId() { return ++mLastClientId; }

    /// Sends a text message to every client except `except` (may be null).
    void broadcastText(const std::string& message, const WebSocketSession* except);
    /// Called on the render thread: hands the frame over to the I/O thread for every client.
    void publishFrame(std::shared_ptr<const EncodedFrame> frame);
    size_t clientCount() const { return mClients.size(); }

private:
    asio::io_context& mIoc;
    Session& mSession;
    RenderService* mRender = nullptr;
    std::set<WebSocketSession*> mClients;
    uint64_t mLastClientId = 0;
};

} // namespace dfb::net
