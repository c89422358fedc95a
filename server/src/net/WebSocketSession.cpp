#include "net/WebSocketSession.h"

#include <dfb/protocol/Codec.h>

namespace dfb::net {

// Largest text message accepted from a client: edits are small; anything bigger is a mistake or
// an attack and closes the connection (Beast enforces it while reading).
constexpr size_t MAX_MESSAGE_BYTES = 1 << 20;

WebSocketSession::WebSocketSession(tcp::socket&& socket, std::shared_ptr<SharedState> state)
    : mWs(std::move(socket)), mState(std::move(state)) {}

WebSocketSession::~WebSocketSession() {
    if (mJoined) mState->leave(this);
}

void WebSocketSession::run(http::request<http::string_body> req) {
    mWs.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    mWs.read_message_max(MAX_MESSAGE_BYTES);
    mWs.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& res) { res.set(http::field::server, "dfb-server"); }));
    mWs.async_accept(req, beast::bind_front_handler(&WebSocketSession::onAccept, shared_from_this()));
}

void WebSocketSession::onAccept(error_code ec) {
    if (ec) return fail(ec, "websocket accept");
    mClientId = mState->nextClientId();
    mState->join(this);
    mJoined = true;
    sendText(std::make_shared<const std::string>(
        protocol::encodeWelcome(mState->session().description(), mState->session().rig(), mClientId)));
    // A new client sees the current image at once, without waiting for somebody's edit.
    if (auto f = mState->render().latestFrame()) sendFrame(f);
    else mState->render().requestFrame();
    doRead();
}

void WebSocketSession::doRead() {
    mWs.async_read(mBuffer, beast::bind_front_handler(&WebSocketSession::onRead, shared_from_this()));
}

void WebSocketSession::onRead(error_code ec, size_t) {
    if (ec) return fail(ec, "websocket read");
    if (!mWs.got_text()) {
        sendText(std::make_shared<const std::string>(
            protocol::encodeError(ErrorCode::Protocol, "binary messages are not accepted from clients", std::nullopt)));
    } else {
        handleText(beast::buffers_to_string(mBuffer.data()));
    }
    mBuffer.consume(mBuffer.size());
    doRead();
}

void WebSocketSession::handleText(const std::string& text) {
    auto msg = protocol::parseClientMessage(text);
    if (!msg) {
        // Name the sequence number if the message had one, so the client can match the error.
        std::optional<uint64_t> seq;
        auto j = nlohmann::json::parse(text, nullptr, false);
        if (j.is_object() && j.contains("seq") && j["seq"].is_number_unsigned()) seq = j["seq"].get<uint64_t>();
        sendText(std::make_shared<const std::string>(protocol::encodeError(msg.error().code, msg.error().message, seq)));
        return;
    }
    if (auto* edit = std::get_if<protocol::EditMessage>(&msg.value())) {
        auto version = mState->session().applyEdit(edit->changes);
        if (!version) {
            sendText(std::make_shared<const std::string>(
                protocol::encodeError(version.error().code, version.error().message, edit->seq)));
            return;
        }
        sendText(std::make_shared<const std::string>(protocol::encodeAck(edit->seq, version.value())));
        mState->broadcastText(protocol::encodeChange(version.value(), mClientId, edit->changes), this);
        mState->render().requestFrame();
    }
    // hello: accepted; nothing to do in v0 beyond validation.
}

void WebSocketSession::sendText(std::shared_ptr<const std::string> message) {
    mTextQueue.push_back(std::move(message));
    if (!mWriting) writeNext();
}

void WebSocketSession::sendFrame(std::shared_ptr<const EncodedFrame> frame) {
    mPendingFrame = std::move(frame); // replaces an older frame that was not sent yet
    if (!mWriting) writeNext();
}

void WebSocketSession::writeNext() {
    // Text first: acks and changes are small and order matters for them.
    if (!mTextQueue.empty()) {
        mWriting = true;
        mWritingText = std::move(mTextQueue.front());
        mTextQueue.pop_front();
        mWs.text(true);
        mWs.async_write(asio::buffer(*mWritingText),
                        beast::bind_front_handler(&WebSocketSession::onWrite, shared_from_this()));
    } else if (mPendingFrame) {
        mWriting = true;
        mWritingFrame = std::move(mPendingFrame);
        mPendingFrame.reset();
        mWs.binary(true);
        mWs.async_write(asio::buffer(*mWritingFrame->message),
                        beast::bind_front_handler(&WebSocketSession::onWrite, shared_from_this()));
    }
}

void WebSocketSession::onWrite(error_code ec, size_t) {
    mWriting = false;
    mWritingText.reset();
    mWritingFrame.reset();
    if (ec) return fail(ec, "websocket write");
    writeNext();
}

} // namespace dfb::net
