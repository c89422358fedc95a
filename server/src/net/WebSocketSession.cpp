#include "net/WebSocketSession.h"

#include "net/SharedState.h"

#include <dfb/protocol/Messages.h>

#include <cstdio>

namespace dfb::net {

namespace {
// A client that lets this many text messages pile up (it does not read) is disconnected: it
// could not keep a consistent rig anyway, and the server must not hold unbounded memory for it.
constexpr size_t MAX_QUEUED_TEXTS = 4096;
} // namespace

WebSocketSession::WebSocketSession(tcp::socket&& socket, std::shared_ptr<SharedState> state, std::shared_ptr<SessionHub> hub,
                                   protocol::Role role, std::shared_ptr<void> slot)
    : mSlot(std::move(slot)), mWs(std::move(socket)), mState(std::move(state)), mHub(std::move(hub)), mRole(role) {}

WebSocketSession::~WebSocketSession() {
    if (mJoined) {
        mHub->leave(this);
        mHub->metrics().clientJoined(mHub->id(), protocol::toString(mRole), -1);
        // Tell the others someone left (posted: this object is being destroyed).
        asio::post(mState->ioc(), [hub = mHub] { hub->broadcastPresence(); });
    }
}

protocol::ClientInfo WebSocketSession::info() const { return {mClientId, mName, mRole, mEditing}; }

void WebSocketSession::run(http::request<http::string_body> req) {
    mWs.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    mWs.read_message_max(protocol::MAX_TEXT_MESSAGE_BYTES);
    mWs.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& res) { res.set(http::field::server, "dfb-server"); }));
    mWs.async_accept(req, beast::bind_front_handler(&WebSocketSession::onAccept, shared_from_this()));
}

void WebSocketSession::onAccept(error_code ec) {
    if (ec) return fail(ec, "websocket accept");
    if (const size_t max = mState->limits().maxClientsPerSession; mHub->clientCount() >= max) {
        // Accepted so that the client can read why (a browser sees nothing of a refused
        // upgrade's body); 1013 = try again later. The reason must stay under 123 bytes.
        mClosing = true;
        mState->metrics().connectionRefused();
        const std::string reason = "session has the maximum of " + std::to_string(max) + " clients (--max-clients-per-session)";
        mWs.async_close(websocket::close_reason(websocket::close_code::try_again_later, reason),
                        [self = shared_from_this()](error_code e) { if (e) fail(e, "websocket close"); });
        return;
    }
    mClientId = mState->nextClientId();
    mName = "client-" + std::to_string(mClientId);
    mHub->join(this);
    mJoined = true;
    mHub->metrics().clientJoined(mHub->id(), protocol::toString(mRole), 1);
    protocol::WelcomeInfo w;
    w.clientId = mClientId;
    w.role = mRole;
    w.sessionId = mHub->id();
    w.session = mHub->session().description();
    w.rig = mHub->session().rig();
    w.view = mView;
    w.clients = mHub->clients();
    w.undoDepth = mHub->session().undoDepth();
    w.redoDepth = mHub->session().redoDepth();
    if (mRole == protocol::Role::Editor) w.viewerToken = mHub->tokens().viewer;
    reply(protocol::encodeWelcome(w));
    mHub->broadcastPresence();
    // A new client sees the current image at once, without waiting for somebody's edit.
    mViewDirty = true;
    pumpFrames();
    doRead();
}

void WebSocketSession::doRead() {
    mWs.async_read(mBuffer, beast::bind_front_handler(&WebSocketSession::onRead, shared_from_this()));
}

void WebSocketSession::onRead(error_code ec, size_t) {
    if (ec) return fail(ec, "websocket read");
    if (!mWs.got_text()) {
        replyError(makeError(ErrorCode::Protocol, "binary messages are not accepted from clients"), std::nullopt);
    } else {
        handleText(beast::buffers_to_string(mBuffer.data()));
    }
    mBuffer.consume(mBuffer.size());
    doRead();
}

void WebSocketSession::replyError(const Error& e, std::optional<uint64_t> seq) {
    reply(protocol::encodeError(e.code, mState->redact(e.message), seq));
}

void WebSocketSession::setEditing(const std::string& what) {
    if (what == mEditing) return;
    mEditing = what;
    mHub->broadcastPresence();
}

void WebSocketSession::handleText(const std::string& text) {
    auto parsed = protocol::parseClientMessage(text);
    if (!parsed) return replyError(parsed.error(), protocol::peekSeq(text));
    const Author me{mClientId, mName};
    Session& session = mHub->session();
    // Changes of the rig: refused for viewers, else journaled, acknowledged and broadcast.
    auto change = [&](uint64_t seq, auto&& doIt) {
        if (mRole != protocol::Role::Editor) {
            mHub->metrics().editRefused(mHub->id());
            return replyError(makeError(ErrorCode::Forbidden, "this connection has a viewer token: viewers cannot change the rig"), seq);
        }
        Result<ChangeOutcome> r = doIt();
        if (!r) {
            mHub->metrics().editRefused(mHub->id());
            return replyError(r.error(), seq);
        }
        nlohmann::json extra = nlohmann::json::object();
        if (!r->overwrote.empty()) extra["overwrote"] = r->overwrote;
        if (r->info.rig) extra["kind"] = r->info.kind;
        reply(protocol::encodeAck(seq, r->info.rigVersion, extra));
        mHub->published(r.value(), this);
    };
    std::visit(
        [&](auto&& m) {
            using T = std::decay_t<decltype(m)>;
            if constexpr (std::is_same_v<T, protocol::HelloMessage>) {
                if (!m.name.empty()) mName = m.name;
                mHub->broadcastPresence();
            } else if constexpr (std::is_same_v<T, protocol::EditMessage>) {
                change(m.seq, [&] { return session.edit(m.changes, me, m.base, m.ifVersion, m.merge); });
                if (mRole == protocol::Role::Editor) {
                    const std::string& p = m.changes.front().path;
                    setEditing(p.substr(0, p.find('.')));
                }
            } else if constexpr (std::is_same_v<T, protocol::UndoMessage>) {
                change(m.seq, [&] { return session.undo(me); });
            } else if constexpr (std::is_same_v<T, protocol::RedoMessage>) {
                change(m.seq, [&] { return session.redo(me); });
            } else if constexpr (std::is_same_v<T, protocol::TimeMessage>) {
                change(m.seq, [&] { return session.setTime(m.seconds, me); });
            } else if constexpr (std::is_same_v<T, protocol::ViewMessage>) {
                auto v = protocol::applyViewJson(mView, m.settings);
                if (!v) return replyError(v.error(), m.seq);
                mView = v.value();
                mViewDirty = true;
                // Every frame after the ack is in the new view: one not yet written is dropped.
                ++mViewGeneration;
                mPendingFrame.reset();
                reply(protocol::encodeAck(m.seq, session.rigVersion(), {{"view", protocol::toJson(mView)}}));
                pumpFrames();
            } else if constexpr (std::is_same_v<T, protocol::PickMessage>) {
                mHub->render().requestPick(m.x, m.y, [self = weak_from_this(), seq = m.seq, ioc = &mState->ioc()](Result<nlohmann::json> r) {
                    asio::post(*ioc, [self, seq, r = std::move(r)] {
                        auto s = self.lock();
                        if (!s) return;
                        if (!r) s->replyError(r.error(), seq);
                        else s->reply(protocol::encodePickResult(seq, r.value()));
                    });
                });
            } else if constexpr (std::is_same_v<T, protocol::PresenceMessage>) {
                setEditing(m.editing.value_or(""));
            }
        },
        parsed.value());
}

void WebSocketSession::sendText(std::shared_ptr<const std::string> message) {
    if (mClosing) return;
    if (mTextQueue.size() >= MAX_QUEUED_TEXTS) {
        std::fprintf(stderr, "dfb-server: session %s: client %llu does not read its messages: disconnected\n", mHub->id().c_str(),
                     static_cast<unsigned long long>(mClientId));
        mClosing = true;
        mTextQueue.clear();
        beast::get_lowest_layer(mWs).socket().close();
        return;
    }
    mTextQueue.push_back(std::move(message));
    if (!mWriting) writeNext();
}

void WebSocketSession::frameAvailable(uint64_t serial) {
    mAvailableSerial = std::max(mAvailableSerial, serial);
    pumpFrames();
}

void WebSocketSession::pumpFrames() {
    if (mClosing || mEncodePending || mWriting || mPendingFrame) return;
    if (!mViewDirty && mAvailableSerial <= mSentSerial) return;
    mEncodePending = true;
    mViewDirty = false;
    mHub->render().requestEncoded(mView, [self = weak_from_this(), ioc = &mState->ioc(), gen = mViewGeneration](
                                             Result<std::shared_ptr<const EncodedFrame>> f) {
        asio::post(*ioc, [self, gen, f = std::move(f)]() mutable {
            if (auto s = self.lock()) s->onEncoded(gen, std::move(f));
        });
    });
}

void WebSocketSession::onEncoded(uint64_t viewGeneration, Result<std::shared_ptr<const EncodedFrame>> frame) {
    mEncodePending = false;
    if (viewGeneration != mViewGeneration) {
        pumpFrames(); // encoded for settings the client has replaced since
        return;
    }
    if (!frame) {
        // The view cannot be rendered (say its light was deleted): say so and fall back to the
        // beauty image, keeping the encoding.
        replyError(makeError(frame.error().code, "view output '" + mView.output + "': " + frame.error().message), std::nullopt);
        if (!(mView.output == "beauty")) {
            protocol::ViewSettings fallback;
            fallback.encoding = mView.encoding;
            fallback.quality = mView.quality;
            mView = fallback;
            mViewDirty = true;
            ++mViewGeneration;
            reply(protocol::encodeAck(0, mHub->session().rigVersion(), {{"view", protocol::toJson(mView)}, {"reason", "fallback"}}));
        }
        pumpFrames();
        return;
    }
    auto f = std::move(frame.value());
    mAvailableSerial = std::max(mAvailableSerial, f->imageSerial);
    mSentSerial = std::max(mSentSerial, f->imageSerial);
    if (f->message == mLastMessage) {
        pumpFrames(); // the same bytes as the last frame (an output a refinement does not change)
        return;
    }
    mLastMessage = f->message;
    mPendingFrame = std::move(f);
    if (!mWriting) writeNext();
}

void WebSocketSession::writeNext() {
    if (mClosing) return;
    // Text first: acks and changes are small and order matters for them.
    if (!mTextQueue.empty()) {
        mWriting = true;
        mWritingText = std::move(mTextQueue.front());
        mTextQueue.pop_front();
        mHub->metrics().bytesSent(mHub->id(), mWritingText->size());
        mWs.text(true);
        mWs.async_write(asio::buffer(*mWritingText), beast::bind_front_handler(&WebSocketSession::onWrite, shared_from_this()));
    } else if (mPendingFrame) {
        mWriting = true;
        mWritingFrame = std::move(mPendingFrame);
        mPendingFrame.reset();
        mHub->metrics().frameSent(mHub->id(), mWritingFrame->message->size());
        mWs.binary(true);
        mWs.async_write(asio::buffer(*mWritingFrame->message),
                        beast::bind_front_handler(&WebSocketSession::onWrite, shared_from_this()));
    }
}

void WebSocketSession::onWrite(error_code ec, size_t) {
    mWriting = false;
    mWritingText.reset();
    mWritingFrame.reset();
    if (ec) {
        mClosing = true;
        return fail(ec, "websocket write");
    }
    writeNext();
    pumpFrames();
}

} // namespace dfb::net
