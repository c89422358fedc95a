#pragma once
// The render thread of one session: owns the Engine (and so the GL context) and turns rig
// versions into images, and images into the encodings clients ask for.
//
// Rendering coalesces: however many changes arrive while a frame renders, the next frame shows
// the newest rig, once. Encoding is pulled, not pushed: a client asks for a frame only when it
// can send one, and gets the newest image encoded for its view settings; equal settings share one
// encoding per version. So a frame nobody needs is never encoded, and a slow client skips
// versions instead of queueing them.

#include "session/Metrics.h"
#include "session/Session.h"

#include <dfb/protocol/Messages.h>
#include <dfb/server/Engine.h>

#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

namespace dfb {

/// A frame ready for the wire: the binary message (32-byte header + image bytes), shared by every
/// client with the same view settings.
struct EncodedFrame {
    uint64_t frameNumber = 0;
    uint64_t rigVersion = 0;
    protocol::Encoding encoding = protocol::Encoding::Jpeg;
    std::shared_ptr<const std::vector<uint8_t>> message;
    FrameStats stats;
    double encodeMs = 0;
    /// The image bytes alone (after the header).
    const uint8_t* image() const { return message->data() + protocol::FRAME_HEADER_BYTES; }
    size_t imageSize() const { return message->size() - protocol::FRAME_HEADER_BYTES; }
};

class RenderService {
public:
    /// Called on the render thread after a new rig version has been rendered.
    using VersionCallback = std::function<void(uint64_t rigVersion)>;
    using FrameCallback = std::function<void(Result<std::shared_ptr<const EncodedFrame>>)>;
    using PickCallback = std::function<void(Result<nlohmann::json>)>;

    /// Starts the thread and creates the engine on it; returns its error if that fails. `shot`
    /// must outlive the service (pick reads it); `metrics` may be null.
    static Result<std::unique_ptr<RenderService>> start(const DeepBuffer& shot, ShadowGeometry casters, Session& session,
                                                        VersionCallback onNewVersion, Metrics* metrics);
    ~RenderService();

    /// Asks for a render of the session's current rig; cheap and non-blocking.
    void requestFrame();
    /// Calls `done` on the render thread with the newest rig's image encoded for `view`
    /// (rendering first if the rig changed). Errors: MissingData for an unknown light or layer
    /// of the output, GpuError, IoError.
    void requestEncoded(protocol::ViewSettings view, FrameCallback done);
    /// What is at pixel (x, y): position, normal, object, and each light's contribution there
    /// (`done` on the render thread). InvalidValue outside the image.
    void requestPick(int x, int y, PickCallback done);
    /// The newest rendered rig version (0 before the first frame).
    uint64_t renderedVersion() const;
    std::string deviceDescription() const { return mDevice; }

private:
    RenderService(const DeepBuffer& shot, Session& session, VersionCallback cb, Metrics* metrics)
        : mShot(shot), mSession(session), mOnNewVersion(std::move(cb)), mMetrics(metrics) {}
    void run(ShadowGeometry casters, std::promise<Status>* ready);
    Result<std::shared_ptr<const EncodedFrame>> encode(Engine& engine, const Rig& rig, const protocol::ViewSettings& view);
    Result<nlohmann::json> pick(Engine& engine, const Rig& rig, int x, int y);

    const DeepBuffer& mShot;
    Session& mSession;
    VersionCallback mOnNewVersion;
    Metrics* mMetrics;
    std::string mDevice;
    std::thread mThread;
    mutable std::mutex mMutex;
    std::condition_variable mWake;
    bool mStop = false;
    bool mFrameWanted = false;
    uint64_t mRenderedVersion = 0;
    std::deque<std::pair<protocol::ViewSettings, FrameCallback>> mEncodeRequests;
    std::deque<std::tuple<int, int, PickCallback>> mPickRequests;

    // Render thread only.
    Image8 mImage;
    FrameStats mStats;
    uint64_t mImageVersion = ~0ull;
    uint64_t mFrameNumber = 0;
    std::map<std::string, std::shared_ptr<const EncodedFrame>> mEncoded; // by view key, for mImageVersion
};

} // namespace dfb
