#pragma once
// The render thread: owns the Engine (and so the GL context) and turns rig versions into encoded
// frames. Requests coalesce: however many edits arrive while a frame renders, the next frame
// shows the newest rig, once.

#include "session/Session.h"

#include <dfb/server/Engine.h>
#include <dfb/server/Outputs.h>

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
    bool preview = false; ///< rendered with preview shadow maps while edits stream in; a refined
                          ///< frame of the same rig version follows when they stop
};

class RenderService {
public:
    using FrameCallback = std::function<void(std::shared_ptr<const EncodedFrame>)>;
    using OutputCallback = std::function<void(Result<EncodedImage>, uint64_t rigVersion)>;

    /// Starts the thread and creates the engine on it; returns its error if that fails. `shot`
    /// must outlive the service (G-buffer layer outputs read it).
    static Result<std::unique_ptr<RenderService>> start(const DeepBuffer& shot, ShadowGeometry casters, Session& session,
                                                        FrameCallback onFrame, int jpegQuality);

    /// Progressive refinement (DESIGN section 6): an edit arriving within `window` of the previous
    /// one is rendered with preview shadow maps; when no edit has come for `settle`, the rig is
    /// rendered again at full quality and published as a refined frame. Zero window disables it.
    void setRefinement(std::chrono::milliseconds window, std::chrono::milliseconds settle);
    ~RenderService();

    /// Asks for a frame of the session's current rig; cheap and non-blocking.
    void requestFrame();
    /// Calls `done` on the render thread with one output of the current rig, encoded
    /// (dfb/server/Outputs.h: beauty, light:NAME, shadow:NAME, layer:NAME as JPEG, PNG or EXR).
    void requestOutput(OutputRequest request, OutputCallback done);
    /// The newest encoded frame, or null before the first one.
    std::shared_ptr<const EncodedFrame> latestFrame() const;
    std::string deviceDescription() const { return mDevice; }

private:
    RenderService(Session& session, FrameCallback onFrame, int quality)
        : mSession(session), mOnFrame(std::move(onFrame)), mQuality(quality) {}
    void run(const DeepBuffer* shot, ShadowGeometry casters, std::promise<Status>* ready);
    void publish(const Image8& image, uint64_t rigVersion, const FrameStats& stats, bool preview);

    Session& mSession;
    FrameCallback mOnFrame;
    int mQuality;
    std::string mDevice;
    std::thread mThread;
    mutable std::mutex mMutex;
    std::condition_variable mWake;
    bool mStop = false;
    bool mFrameWanted = false;
    std::deque<std::pair<OutputRequest, OutputCallback>> mOutputRequests;
    std::shared_ptr<const EncodedFrame> mLatest;
    uint64_t mFrameNumber = 0;
    std::chrono::milliseconds mRefineWindow{250}, mRefineSettle{150};
};

} // namespace dfb
