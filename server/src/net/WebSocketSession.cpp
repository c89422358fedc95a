#include "net/WebSocketSession.h"

#include "net/SharedState.h"

#include <dfb/protocol/Messages.h>

#include <cstdio>

#include <sys/ioctl.h>
#include <linux/sockios.h>

namespace dfb::net {

namespace {
using Clock = std::chrono::steady_clock;
// Replies (acks, errors, picks) a client may leave unread: a client sending that many messages
// without reading one answer is not reading, and the server must not hold unbounded memory.
constexpr size_t MAX_QUEUED_TEXTS = 4096;
// Other clients' changes are sent at most once per interval, coalesced: 64 editors at 10 edits/s
// were 40,000 messages a second for the network thread, which dropped healthy clients.
// 40 ms is below a frame at interactive rates, so the panels follow the image.
constexpr auto CHANGE_INTERVAL = std::chrono::milliseconds(40);
// One coalesced message carries at most this many changes and about this many bytes (the rest
// follow at once): a change may carry a large value (a whole key map), and clients bound the
// messages they read.
constexpr size_t MAX_CHANGES_PER_MESSAGE = 256;
constexpr size_t MAX_BYTES_PER_MESSAGE = 1 << 20;
// Changes held for a client that has not taken any for long: only reached by a client that
// reads nothing for many seconds in a very busy session (STALL_TIMEOUT usually comes first).
constexpr size_t MAX_PENDING_CHANGES = 100000;
// A client is "not reading" when its socket accepts no byte for this long while a write waits
// (a slow link still drains its buffer, a stopped reader does not).
constexpr auto STALL_TIMEOUT = std::chrono::seconds(20);
constexpr auto STALL_CHECK = std::chrono::seconds(2);
// Drag messages a client may have waiting for the solver: the browser keeps one update in flight;
// a script that sends faster is told to wait instead of queueing work without end.
constexpr int MAX_DRAG_JOBS = 16;

// Bytes written to the socket that the peer has not acknowledged yet (Linux SIOCOUTQ); -1 when
// unknown.
int unsentBytes(int fd) {
    int n = 0;
    return ::ioctl(fd, SIOCOUTQ, &n) == 0 ? n : -1;
}
} // namespace

// One drag of this client. `grab` lives on the render thread (written by the begin's job, read by
// the updates' jobs, which run after it in order); the rest on the network thread.
struct WebSocketSession::DragState {
    std::optional<DragGrab> grab;             // render thread
    bool applied = false;                     // network thread: an update changed the rig (the next merges)
    std::vector<protocol::Change> restore;    // network thread: what a cancel applies
};

WebSocketSession::WebSocketSession(Stream&& stream, std::shared_ptr<SharedState> state, std::shared_ptr<SessionHub> hub,
                                   protocol::Role role, std::shared_ptr<void> slot)
    : mSlot(std::move(slot)), mWs(std::move(stream)), mState(std::move(state)), mHub(std::move(hub)), mRole(role),
      mFlushTimer(mWs.get_executor()), mStallTimer(mWs.get_executor()) {}

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
    if (mClosing || mCloseWith) {
        // Going away: no more reads (async_close reads up to the peer's close frame itself).
        mBuffer.consume(mBuffer.size());
        return;
    }
    mHub->touch();
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
        answerChange(seq, doIt());
    };
    std::visit(
        [&](auto&& m) {
            using T = std::decay_t<decltype(m)>;
            if constexpr (std::is_same_v<T, protocol::HelloMessage>) {
                if (!m.name.empty()) mName = m.name;
                mHub->broadcastPresence();
            } else if constexpr (std::is_same_v<T, protocol::EditMessage>) {
                change(m.seq, [&] { return session.edit(m.changes, me, m.base, m.ifVersion, m.merge, m.allowFold); });
                if (mRole == protocol::Role::Editor) {
                    const std::string& p = m.changes.front().path;
                    setEditing(p.substr(0, p.find('.')));
                }
            } else if constexpr (std::is_same_v<T, protocol::UndoMessage>) {
                change(m.seq, [&] { return session.undo(me); });
            } else if constexpr (std::is_same_v<T, protocol::RedoMessage>) {
                change(m.seq, [&] { return session.redo(me); });
            } else if constexpr (std::is_same_v<T, protocol::RestoreMessage>) {
                change(m.seq, [&]() -> Result<ChangeOutcome> {
                    auto rig = session.rigAtVersion(m.version);
                    if (!rig) return rig.error();
                    return session.replace(rig.value(), me);
                });
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
                // A client waits for a frame after this ack, even when the new view encodes to
                // the bytes it already has (the same settings again): never skip that one.
                mLastMessage.reset();
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
            } else if constexpr (std::is_same_v<T, protocol::DragMessage>) {
                if (mRole != protocol::Role::Editor) {
                    mHub->metrics().editRefused(mHub->id());
                    return replyError(makeError(ErrorCode::Forbidden, "this connection has a viewer token: viewers cannot drag lights"), m.seq);
                }
                handleDrag(m);
            } else if constexpr (std::is_same_v<T, protocol::AnnotateMessage>) {
                // Any role: a review note is not an edit of the rig (session/Annotations.h).
                auto out = mHub->annotations().add(m, mHub->shot().width, mHub->shot().height, session.rigVersion(), mName);
                if (!out) return replyError(out.error(), m.seq);
                reply(protocol::encodeAck(m.seq, session.rigVersion(), {{"annotation", out.value()}}));
                mHub->annotationsChanged();
            }
        },
        parsed.value());
}

void WebSocketSession::answerChange(uint64_t seq, Result<ChangeOutcome> r, nlohmann::json extra) {
    if (!r) {
        mHub->metrics().editRefused(mHub->id());
        return replyError(r.error(), seq);
    }
    if (!r->overwrote.empty()) extra["overwrote"] = r->overwrote;
    if (!r->limited.empty()) extra["limited"] = r->limited;
    if (r->info.rig) extra["kind"] = r->info.kind;
    reply(protocol::encodeAck(seq, r->info.rigVersion, extra));
    mHub->published(r.value(), this);
}

void WebSocketSession::handleDrag(const protocol::DragMessage& m) {
    using protocol::DragPhase;
    const char* phase = protocol::toString(m.phase);
    if (m.phase != DragPhase::Begin && !mDrag) {
        return replyError(makeError(ErrorCode::Protocol, std::string("drag ") + phase + ": no drag is going on (send a begin first)"), m.seq);
    }
    if (mDragJobs >= MAX_DRAG_JOBS) {
        return replyError(makeError(ErrorCode::LimitExceeded, "drag " + std::string(phase) + ": " + std::to_string(MAX_DRAG_JOBS) +
                                                                  " drag messages are waiting for the solver; send the next when one is "
                                                                  "acknowledged"),
                          m.seq);
    }
    if (m.phase == DragPhase::Begin) {
        mDrag = std::make_shared<DragState>(); // a begin ends the drag before
        setEditing(m.light);
    }
    auto state = mDrag;
    if (m.phase == DragPhase::End || m.phase == DragPhase::Cancel) mDrag.reset();
    ++mDragJobs;
    // On the render thread: the begin's pick or the update's pick and solve, never the session's
    // rig (that is applied back here, on the network thread, like any edit).
    Session& session = mHub->session();
    mHub->render().requestPickerJob([self = weak_from_this(), ioc = &mState->ioc(), state, m, &session](const Picker& picker,
                                                                                                      const DeepBuffer& shot) {
        // What the network thread does with the answer.
        auto post = [&](auto&& then) {
            asio::post(*ioc, [self, then = std::move(then)]() mutable {
                auto s = self.lock();
                if (!s) return;
                --s->mDragJobs;
                then(*s);
            });
        };
        switch (m.phase) {
        case DragPhase::Begin: {
            DragStart start;
            start.mode = protocol::parseDragMode(m.mode).value(); // validated by the codec
            start.light = m.light;
            start.x = m.x;
            start.y = m.y;
            start.points = m.points;
            auto g = beginDrag(picker, shot, session.rig(), start);
            if (!g) return post([seq = m.seq, e = g.error()](WebSocketSession& s) { s.replyError(e, seq); });
            state->grab = g.value();
            return post([seq = m.seq, state, restore = restoreChanges(g.value()), j = toJson(g.value())](WebSocketSession& s) mutable {
                state->restore = std::move(restore);
                s.reply(protocol::encodeAck(seq, s.mHub->session().rigVersion(), {{"drag", j}}));
            });
        }
        case DragPhase::Update: {
            if (!state->grab) {
                return post([seq = m.seq](WebSocketSession& s) {
                    s.replyError(makeError(ErrorCode::Protocol, "drag update: the drag's begin was refused (see its error)"), seq);
                });
            }
            auto step = dragTo(picker, shot, *state->grab, m.x, m.y);
            if (!step) return post([seq = m.seq, e = step.error()](WebSocketSession& s) { s.replyError(e, seq); });
            return post([seq = m.seq, state, changes = step->changes, j = toJson(step.value())](WebSocketSession& s) {
                if (changes.empty()) return s.reply(protocol::encodeAck(seq, s.mHub->session().rigVersion(), {{"drag", j}}));
                const Author me{s.mClientId, s.mName};
                auto r = s.mHub->session().edit(changes, me, std::nullopt, std::nullopt, /*merge=*/state->applied);
                if (r) state->applied = true;
                s.answerChange(seq, std::move(r), {{"drag", j}});
            });
        }
        case DragPhase::End:
        case DragPhase::Cancel:
            return post([seq = m.seq, state, cancel = m.phase == DragPhase::Cancel](WebSocketSession& s) {
                const nlohmann::json j{{"ended", cancel ? "cancel" : "end"}};
                if (!cancel || !state->applied) return s.reply(protocol::encodeAck(seq, s.mHub->session().rigVersion(), {{"drag", j}}));
                // The light as it was at the begin, in the drag's own undo step.
                const Author me{s.mClientId, s.mName};
                s.answerChange(seq, s.mHub->session().edit(state->restore, me, std::nullopt, std::nullopt, /*merge=*/true), {{"drag", j}});
            });
        }
    });
}

void WebSocketSession::closeWith(websocket::close_code code, std::string reason) {
    if (mClosing || mCloseWith) return;
    // A close reason must stay under 123 bytes (RFC 6455 section 5.5).
    if (reason.size() > 120) reason.resize(120);
    mCloseWith = websocket::close_reason(code, reason);
    if (!mWriting) sendClose();
}

void WebSocketSession::sendClose() {
    mClosing = true;
    mTextQueue.clear();
    mPendingChanges.clear();
    mFlushTimer.cancel();
    mStallTimer.cancel();
    mWs.async_close(*mCloseWith, [self = shared_from_this()](error_code e) {
        if (e) fail(e, "websocket close");
    });
}

void WebSocketSession::disconnect(const char* why) {
    if (mClosing) return;
    std::fprintf(stderr, "dfb-server: session %s: client %llu %s: disconnected\n", mHub->id().c_str(),
                 static_cast<unsigned long long>(mClientId), why);
    mClosing = true;
    mTextQueue.clear();
    mPendingChanges.clear();
    mFlushTimer.cancel();
    mStallTimer.cancel();
    error_code ignored;
    beast::get_lowest_layer(mWs).socket().close(ignored);
}

void WebSocketSession::sendText(std::shared_ptr<const std::string> message) {
    if (mClosing) return;
    if (mTextQueue.size() >= MAX_QUEUED_TEXTS) return disconnect("does not read the answers to its messages");
    mTextQueue.push_back(std::move(message));
    if (!mWriting) writeNext();
}

void WebSocketSession::changeAvailable(std::shared_ptr<const BroadcastChange> change) {
    if (mClosing || !mJoined) return;
    // A whole rig is the state at its version: the changes before it need not be sent.
    if (change->info.rig) mPendingChanges.clear();
    mPendingChanges.push_back(std::move(change));
    if (mPendingChanges.size() > MAX_PENDING_CHANGES) return disconnect("does not read its messages");
    if (!mWriting) writeNext();
}

void WebSocketSession::presenceChanged() {
    if (mClosing || !mJoined) return;
    mPresenceDirty = true;
    if (!mWriting) writeNext();
}

bool WebSocketSession::changesDue() const { return Clock::now() - mLastChangesSent >= CHANGE_INTERVAL; }

void WebSocketSession::armFlush() {
    if (mFlushArmed) return;
    mFlushArmed = true;
    mFlushTimer.expires_at(mLastChangesSent + CHANGE_INTERVAL);
    mFlushTimer.async_wait([self = weak_from_this()](error_code ec) {
        auto s = self.lock();
        if (!s) return;
        s->mFlushArmed = false;
        if (!ec && !s->mWriting) s->writeNext();
    });
}

std::shared_ptr<const std::string> WebSocketSession::takeChanges() {
    // Only the first pending change can be a whole rig (changeAvailable): it goes alone.
    size_t n = 1, bytes = mPendingChanges.front()->encoded->size();
    if (!mPendingChanges.front()->info.rig) {
        while (n < mPendingChanges.size() && n < MAX_CHANGES_PER_MESSAGE && bytes + mPendingChanges[n]->encoded->size() <= MAX_BYTES_PER_MESSAGE) {
            bytes += mPendingChanges[n++]->encoded->size();
        }
    }
    if (n == 1) {
        auto m = mPendingChanges.front()->encoded;
        mPendingChanges.erase(mPendingChanges.begin());
        return m;
    }
    std::vector<const protocol::ChangeInfo*> batch;
    batch.reserve(n);
    for (size_t i = 0; i < n; ++i) batch.push_back(&mPendingChanges[i]->info);
    auto m = std::make_shared<const std::string>(protocol::encodeChanges(batch));
    mPendingChanges.erase(mPendingChanges.begin(), mPendingChanges.begin() + std::ptrdiff_t(n));
    return m;
}

void WebSocketSession::armStallCheck() {
    if (mStallArmed) return;
    mStallArmed = true;
    mStallTimer.expires_after(STALL_CHECK);
    mStallTimer.async_wait([self = weak_from_this()](error_code ec) {
        auto s = self.lock();
        if (!s) return;
        s->mStallArmed = false;
        if (ec || s->mClosing || !s->mWriting) return;
        const int unsent = unsentBytes(beast::get_lowest_layer(s->mWs).socket().native_handle());
        // Bytes left the socket since the last look: the peer reads, however slowly.
        if (unsent >= 0 && s->mUnsentAtCheck >= 0 && unsent < s->mUnsentAtCheck) s->mWriteStarted = Clock::now();
        s->mUnsentAtCheck = unsent;
        if (Clock::now() - s->mWriteStarted >= STALL_TIMEOUT) return s->disconnect("accepts no data (it does not read)");
        s->armStallCheck();
    });
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
    if (mClosing || mWriting) return;
    std::shared_ptr<const std::string> text;
    // Replies first: they are small, in order, and what this client waits for.
    if (!mTextQueue.empty()) {
        text = std::move(mTextQueue.front());
        mTextQueue.pop_front();
    } else if (!mPendingChanges.empty() || mPresenceDirty) {
        // Others' changes and presence, at most once per interval (all that is pending goes out
        // back to back, then the interval starts again).
        if (mFlushing || changesDue()) {
            if (!mFlushing) mLastChangesSent = Clock::now();
            mFlushing = true;
            if (!mPendingChanges.empty()) {
                text = takeChanges();
            } else {
                mPresenceDirty = false;
                text = std::make_shared<const std::string>(protocol::encodePresence(mHub->clients()));
            }
            mFlushing = !mPendingChanges.empty() || mPresenceDirty;
        } else {
            armFlush();
        }
    }
    if (text) {
        mWriting = true;
        mWritingText = std::move(text);
        mHub->metrics().bytesSent(mHub->id(), mWritingText->size());
        mWs.text(true);
        startWrite(asio::buffer(*mWritingText));
    } else if (mPendingFrame) {
        mWriting = true;
        mWritingFrame = std::move(mPendingFrame);
        mPendingFrame.reset();
        mHub->metrics().frameSent(mHub->id(), mWritingFrame->message->size());
        mWs.binary(true);
        startWrite(asio::buffer(*mWritingFrame->message));
    }
}

void WebSocketSession::startWrite(asio::const_buffer bytes) {
    mWriteStarted = Clock::now();
    mUnsentAtCheck = -1;
    armStallCheck();
    mWs.async_write(bytes, beast::bind_front_handler(&WebSocketSession::onWrite, shared_from_this()));
}

void WebSocketSession::onWrite(error_code ec, size_t) {
    mWriting = false;
    mWritingText.reset();
    mWritingFrame.reset();
    if (ec) {
        mClosing = true;
        return fail(ec, "websocket write");
    }
    if (mCloseWith) return sendClose();
    writeNext();
    pumpFrames();
}

} // namespace dfb::net
