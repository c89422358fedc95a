#pragma once
// The render thread: owns the Engine (and so the GL context) and turns rig versions into encoded
// frames. Requests coalesce: however many edits arrive while a frame renders, the next frame
// shows the newest rig, once.

#include "session/Session.h"

#include <dfb/server/Engine.h>

#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <thread>

namespace dfb {

/// A frame ready for the wire: the binary message (32-byte header + JPEG), shared by all clients.
struct EncodedFrame {
    uint64_t frameNumber = 0;
    uint64_t rigVersion = 0;
    std::shared_ptr<const std::vector<uint8_t>> message;
    FrameStats stats;
    double encodeMs = 0;
};

class RenderService {
public:
    using FrameCallback = std::function<void(std::shared_ptr<const EncodedFrame>)>;
    using ImageCallback = std::function<void(Result<Image8>, uint64_t rigVersion)>;

    /// Starts the thread and creates the engine on it; returns its error if that fails.
    static Result<std::unique_ptr<RenderService>> start(const DeepBuffer& shot, ShadowGeometry casters, Session& session,
                                                        FrameCallback onFrame, int jpegQuality);
    ~RenderService();

    /// Asks for a frame of the session's current rig; cheap and non-blocking.
    void requestFrame();
    /// Calls `done` on the render thread with an image of the current rig (rendered if needed).
    /// `output`: "beauty" (default), "light:NAME" (one light alone, with the rig's exposure) or
    /// "shadow:NAME" (that light's shadow mask: visibility as grey, black where it does not reach).
    void requestImage(ImageCallback done, std::string output = "beauty");
    /// The newest encoded frame, or null before the first one.
    std::shared_ptr<const EncodedFrame> latestFrame() const;
    std::string deviceDescription() const { return mDevice; }

private:
    RenderService(Session& session, FrameCallback onFrame, int quality)
        : mSession(session), mOnFrame(std::move(onFrame)), mQuality(quality) {}
    void run(const DeepBuffer* shot, ShadowGeometry casters, std::promise<Status>* ready);

    Session& mSession;
    FrameCallback mOnFrame;
    int mQuality;
    std::string mDevice;
    std::thread mThread;
    mutable std::mutex mMutex;
    std::condition_variable mWake;
    bool mStop = false;
    bool mFrameWanted = false;
    std::deque<std::pair<ImageCallback, std::string>> mImageRequests;
    std::shared_ptr<const EncodedFrame> mLatest;
};

} // namespace dfb
