#pragma once
// One WebSocket client of one session, with the role its token gave it. Replies to this client
// (welcome, acks, errors, picks) are queued in order and written first; other clients' changes
// and presence are coalesced: at most one change message (all changes since the last one, in
// order) and one presence list per CHANGE_INTERVAL, so a busy session costs each client a bounded
// number of messages whatever the edit rate. Frames are pulled: when nothing is being written, the
// client asks the render thread for the newest image encoded for its own view settings, so it
// never holds more than one frame and a slow client skips versions instead of queueing them. One
// async write in flight at a time (Beast's rule). A client whose socket accepts no bytes for
// STALL_TIMEOUT while a write waits is disconnected as not reading.

#include "net/Beast.h"
#include "net/SessionHub.h"
#include "net/Stream.h"

#include <dfb/protocol/Messages.h>
#include <dfb/server/Drag.h>

#include <chrono>
#include <deque>
#include <memory>
#include <vector>

namespace dfb::net {

class SharedState;

class WebSocketSession : public std::enable_shared_from_this<WebSocketSession> {
public:
    /// `slot`: the connection's place under the per-address limit, held while it lives.
    WebSocketSession(Stream&& stream, std::shared_ptr<SharedState> state, std::shared_ptr<SessionHub> hub,
                     protocol::Role role, std::shared_ptr<void> slot);
    ~WebSocketSession();

    /// Accepts the upgrade request and starts reading.
    void run(http::request<http::string_body> req);
    void sendText(std::shared_ptr<const std::string> message);
    /// Another client's accepted change: sent coalesced with the others of the interval.
    void changeAvailable(std::shared_ptr<const BroadcastChange> change);
    /// The presence list changed: the newest list is sent within the interval.
    void presenceChanged();
    /// A new image (serial) has been rendered: pull it when the connection is free.
    void frameAvailable(uint64_t imageSerial);
    protocol::ClientInfo info() const;
    /// Closes the connection with a close frame (after the write in flight, if any): the session
    /// moved to another node or this node is draining (code 1012, service restart: the page and
    /// dfb-client reconnect). Messages read after it are ignored.
    void closeWith(websocket::close_code code, std::string reason);

private:
    void onAccept(error_code ec);
    void doRead();
    void onRead(error_code ec, size_t bytes);
    void handleText(const std::string& text);
    void reply(const std::string& message) { sendText(std::make_shared<const std::string>(message)); }
    void replyError(const Error& e, std::optional<uint64_t> seq);
    void setEditing(const std::string& what);
    // Acknowledges (and broadcasts) an accepted change of the rig or replies its error.
    void answerChange(uint64_t seq, Result<ChangeOutcome> r, nlohmann::json extra = nlohmann::json::object());
    // Indirect-editing drags (docs/protocol.md "Drags"): solved on the render thread, in order.
    void handleDrag(const protocol::DragMessage& m);
    struct DragState;
    std::shared_ptr<DragState> mDrag; // this client's drag, if one is going on
    int mDragJobs = 0;                // drag messages waiting for the render thread
    void pumpFrames();
    void onEncoded(uint64_t viewGeneration, Result<std::shared_ptr<const EncodedFrame>> frame);
    void writeNext();
    void onWrite(error_code ec, size_t bytes);
    // The next coalesced change message, taken off mPendingChanges (a whole-rig change first).
    std::shared_ptr<const std::string> takeChanges();
    bool changesDue() const;
    void startWrite(asio::const_buffer bytes);
    void armFlush();
    void armStallCheck();
    void disconnect(const char* why);
    void sendClose();

    std::shared_ptr<void> mSlot;
    websocket::stream<Stream> mWs;
    beast::flat_buffer mBuffer;
    std::shared_ptr<SharedState> mState;
    std::shared_ptr<SessionHub> mHub;
    protocol::Role mRole;
    uint64_t mClientId = 0;
    std::string mName;
    std::string mEditing;
    bool mJoined = false;
    bool mClosing = false;
    std::optional<websocket::close_reason> mCloseWith; // closeWith() waits for the write in flight

    protocol::ViewSettings mView;
    bool mViewDirty = true;          // the next frame must be encoded for new view settings
    uint64_t mViewGeneration = 0;    // bumped on every view change: older encodings are dropped
    uint64_t mAvailableSerial = 0;   // newest rendered image we heard of
    uint64_t mSentSerial = 0;        // image of the newest frame taken for sending
    std::shared_ptr<const std::vector<uint8_t>> mLastMessage; // its bytes (not sent twice)
    bool mEncodePending = false;

    bool mWriting = false;
    std::deque<std::shared_ptr<const std::string>> mTextQueue;
    std::vector<std::shared_ptr<const BroadcastChange>> mPendingChanges;
    bool mPresenceDirty = false;
    bool mFlushing = false; // sending everything pending, interval started
    std::chrono::steady_clock::time_point mLastChangesSent{};
    asio::steady_timer mFlushTimer;
    bool mFlushArmed = false;
    // Write progress: when the write in flight began, and the socket's unsent bytes then.
    asio::steady_timer mStallTimer;
    bool mStallArmed = false;
    uint64_t mWriteSerial = 0;
    std::chrono::steady_clock::time_point mWriteStarted{};
    int mUnsentAtCheck = -1;
    std::shared_ptr<const EncodedFrame> mPendingFrame;
    std::shared_ptr<const EncodedFrame> mWritingFrame;
    std::shared_ptr<const std::string> mWritingText;
};

} // namespace dfb::net
