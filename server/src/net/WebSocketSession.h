#pragma once
// One WebSocket client. Text messages are queued in order; frames are not: only the newest
// frame waits while another write is in flight, so a slow client never builds up a queue of
// stale images. One async write in flight at a time (Beast's rule).

#include "net/Beast.h"
#include "net/SharedState.h"

#include <deque>
#include <memory>

namespace dfb::net {

class WebSocketSession : public std::enable_shared_from_this<WebSocketSession> {
public:
    WebSocketSession(tcp::socket&& socket, std::shared_ptr<SharedState> state);
    ~WebSocketSession();

    /// Accepts the upgrade request and starts reading.
    void run(http::request<http::string_body> req);
    void sendText(std::shared_ptr<const std::string> message);
    void sendFrame(std::shared_ptr<const EncodedFrame> frame);

private:
    void onAccept(error_code ec);
    void doRead();
    void onRead(error_code ec, size_t bytes);
    void handleText(const std::string& text);
    void writeNext();
    void onWrite(error_code ec, size_t bytes);

    websocket::stream<beast::tcp_stream> mWs;
    beast::flat_buffer mBuffer;
    std::shared_ptr<SharedState> mState;
    uint64_t mClientId = 0;
    bool mJoined = false;
    bool mWriting = false;
    std::deque<std::shared_ptr<const std::string>> mTextQueue;
    std::shared_ptr<const EncodedFrame> mPendingFrame;
    std::shared_ptr<const EncodedFrame> mWritingFrame;
    std::shared_ptr<const std::string> mWritingText;
};

} // namespace dfb::net
