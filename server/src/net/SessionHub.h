#pragma once
// One session on the network: its Session (rig, history, journal), its render thread, its access
// tokens and its connected WebSocket clients. Every change of the session, from a WebSocket or
// from plain HTTP, goes out through published(), so every client hears of every change.
// I/O thread only, except onNewImage (any thread).

#include "net/Beast.h"
#include "net/FinalRenders.h"
#include "session/Annotations.h"
#include "session/Library.h"
#include "session/Metrics.h"
#include "session/Lease.h"
#include "session/RenderService.h"
#include "session/Session.h"

#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/protocol/Messages.h>

#include <chrono>
#include <memory>
#include <optional>
#include <set>
#include <string>

namespace dfb::net {

class WebSocketSession;

/// An accepted change on its way to the clients: encoded once (the message a client gets when it
/// is the only change of its interval; its size bounds coalesced messages), shared by all.
struct BroadcastChange {
    protocol::ChangeInfo info;
    std::shared_ptr<const std::string> encoded;
};

/// The two tokens of a session: whoever presents one gets its role.
struct SessionTokens {
    std::string editor;
    std::string viewer;
    /// The role `token` opens, or nothing (compared in constant time).
    std::optional<protocol::Role> roleFor(std::string_view token) const;
};

class SessionHub : public std::enable_shared_from_this<SessionHub> {
public:
    SessionHub(asio::io_context& ioc, Metrics& metrics, std::unique_ptr<DeepBuffer> shot, std::unique_ptr<Session> session,
               SessionTokens tokens)
        : mIoc(ioc), mMetrics(metrics), mShot(std::move(shot)), mSession(std::move(session)), mTokens(std::move(tokens)),
          mHousekeeping(ioc) {
        makeFinalRenders();
    }

    /// Starts the periodic work of the session on the I/O thread (rig.json after a burst of
    /// changes, Session::flushSavedRig).
    void startHousekeeping();

    const std::string& id() const { return mSession->id(); }
    Session& session() { return *mSession; }
    const DeepBuffer& shot() const { return *mShot; }
    RenderService& render() { return *mRender; }
    void setRender(std::unique_ptr<RenderService> render) { mRender = std::move(render); }
    /// The session's Cycles final renders (net/FinalRenders.h).
    FinalRenders& finals() { return *mFinals; }
    /// The session's snapshots and saved rigs (session/Library.h); in memory until setLibrary.
    Library& library() { return *mLibrary; }
    void setLibrary(std::unique_ptr<Library> library) { mLibrary = std::move(library); }
    /// Tells every client the library's new list (a `library` message, docs/protocol.md).
    void libraryChanged();
    /// The session's annotations (session/Annotations.h); in memory until setAnnotations.
    Annotations& annotations() { return *mAnnotations; }
    void setAnnotations(std::unique_ptr<Annotations> annotations) { mAnnotations = std::move(annotations); }
    /// Tells every client the whole list of annotations (an `annotations` message,
    /// docs/protocol.md "Annotations"; at most Annotations::MAX_ANNOTATIONS).
    void annotationsChanged();
    /// Sends one text message to every client.
    void broadcastText(std::shared_ptr<const std::string> message);
    Metrics& metrics() { return mMetrics; }
    const SessionTokens& tokens() const { return mTokens; }
    /// The role `token` opens in this session, or nothing (compared in constant time).
    std::optional<protocol::Role> roleFor(std::string_view token) const { return mTokens.roleFor(token); }

    void join(WebSocketSession* ws);
    void leave(WebSocketSession* ws);
    std::vector<protocol::ClientInfo> clients() const;
    size_t clientCount() const { return mClients.size(); }

    /// Tells every client (but `except`, which gets an ack instead) about an accepted change and
    /// asks for a frame of it.
    void published(const ChangeOutcome& outcome, const WebSocketSession* except);
    /// Sends the current presence list to every client.
    void broadcastPresence();
    /// Called on the render thread: a new image is rendered (a new version or a refinement);
    /// clients pull it when they can.
    void onNewImage(uint64_t imageSerial);

    /// The session's lease (session/Lease.h), held while it is open on this node.
    void setLease(std::unique_ptr<Lease> lease) { mLease = std::move(lease); }
    /// A request or a client's message: the session is in use (SharedState's idle close).
    void touch() { mLastActivity = std::chrono::steady_clock::now(); }
    std::chrono::steady_clock::duration idleFor() const { return std::chrono::steady_clock::now() - mLastActivity; }
    std::chrono::steady_clock::duration openFor() const { return std::chrono::steady_clock::now() - mOpened; }
    /// Ends the session on this node (idle, handed over, or the node drains): rig.json written,
    /// later changes refused (Session::close), the lease released, and every client closed with
    /// code 1012 and `reason` so that it reconnects, through the router, to the next owner. The
    /// render thread and memory go when the last connection lets go of the hub.
    void shutdown(const std::string& reason);
    bool closed() const { return mClosed; }

private:
    void makeFinalRenders();

    asio::io_context& mIoc;
    Metrics& mMetrics;
    // Destroyed after the session (its journal) and the render thread, should shutdown() not have
    // released it earlier.
    std::unique_ptr<Lease> mLease;
    std::unique_ptr<DeepBuffer> mShot;
    std::unique_ptr<Session> mSession;
    std::unique_ptr<RenderService> mRender;
    SessionTokens mTokens;
    std::set<WebSocketSession*> mClients;
    asio::steady_timer mHousekeeping;
    std::unique_ptr<FinalRenders> mFinals;
    std::unique_ptr<Library> mLibrary = Library::open({}).value();
    std::unique_ptr<Annotations> mAnnotations = Annotations::open({}).value();
    std::chrono::steady_clock::time_point mOpened = std::chrono::steady_clock::now();
    std::chrono::steady_clock::time_point mLastActivity = mOpened;
    bool mClosed = false;
};

} // namespace dfb::net
