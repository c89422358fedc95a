#pragma once
// The render thread of one session: owns the Engine (and so the GL context) and turns rig
// versions into images, and images into the encodings clients ask for.
//
// Rendering coalesces: however many changes arrive while a frame renders, the next frame shows
// the newest rig, once. While changes stream in (a drag), the beauty is a preview (Engine::
// setPreview) and is rendered again at full quality when they stop (progressive refinement): a
// new image of the same rig version. Encoding is pulled, not pushed: a client asks for a frame only when it
// can send one, and gets the newest image encoded for its view settings; equal settings share one
// encoding per version. So a frame nobody needs is never encoded, and a slow client skips
// versions instead of queueing them.

#include "session/Metrics.h"
#include "session/Session.h"

#include <dfb/protocol/Messages.h>
#include <dfb/server/Engine.h>
#include <dfb/server/Outputs.h>
#include <dfb/server/Picker.h>

#include <chrono>
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
    uint64_t imageSerial = 0; ///< which render of the session it shows (refinements count too)
    bool preview = false;     ///< a preview during a drag: a refined image of the version follows
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
    /// Called on the render thread after a new image has been rendered: a new rig version, or
    /// the refinement of a preview. `imageSerial` counts the images of the session.
    using ImageCallback = std::function<void(uint64_t rigVersion, uint64_t imageSerial)>;
    using FrameCallback = std::function<void(Result<std::shared_ptr<const EncodedFrame>>)>;
    using PickCallback = std::function<void(Result<nlohmann::json>)>;
    /// Work on the session's picker (indirect-editing drags, dfb/server/Drag.h): run on the render
    /// thread in the order asked, after the frame and the picks asked before it.
    using PickerJob = std::function<void(const Picker& picker, const DeepBuffer& shot)>;

    /// Starts the thread and creates the engine on it; returns its error if that fails. `shot`
    /// must outlive the service (pick reads it); `metrics` may be null.
    static Result<std::unique_ptr<RenderService>> start(const DeepBuffer& shot, ShadowGeometry casters, Session& session,
                                                        ImageCallback onNewImage, Metrics* metrics);
    ~RenderService();

    /// Progressive refinement (DESIGN section 6): a change arriving within `window` of the
    /// previous one is rendered as a preview; when no change has come for `settle`, the rig is
    /// rendered again at full quality. A zero window disables it.
    void setRefinement(std::chrono::milliseconds window, std::chrono::milliseconds settle);

    /// Asks for a render of the session's current rig; cheap and non-blocking.
    void requestFrame();
    /// Calls `done` on the render thread with the newest rig's image encoded for `view`
    /// (rendering first if the rig changed). `fullQuality`: never a preview (HTTP requests: a
    /// script wants the real image; a preview on screen is then refined first). Errors:
    /// MissingData for an unknown light, InvalidValue for an unknown layer, GpuError, IoError.
    void requestEncoded(protocol::ViewSettings view, FrameCallback done, bool fullQuality = false);
    /// What is at pixel (x, y): position, normal, object, and each light's contribution there
    /// (`done` on the render thread). InvalidValue outside the image.
    void requestPick(int x, int y, PickCallback done);
    /// Queues `job` (cheap, non-blocking). Jobs that share state keep their order.
    void requestPickerJob(PickerJob job);
    /// The newest image's serial (0 before the first frame).
    uint64_t imageSerial() const;
    std::string deviceDescription() const { return mDevice; }

private:
    RenderService(const DeepBuffer& shot, Session& session, ImageCallback cb, Metrics* metrics)
        : mShot(shot), mSession(session), mOnNewImage(std::move(cb)), mMetrics(metrics) {}
    void run(ShadowGeometry casters, std::promise<Status>* ready);
    Result<std::shared_ptr<const EncodedFrame>> encode(Engine& engine, const Rig& rig, const protocol::ViewSettings& view);
    Result<nlohmann::json> pick(Engine& engine, const Rig& rig, int x, int y);

    const DeepBuffer& mShot;
    Session& mSession;
    ImageCallback mOnNewImage;
    Metrics* mMetrics;
    std::string mDevice;
    std::thread mThread;
    mutable std::mutex mMutex;
    std::condition_variable mWake;
    bool mStop = false;
    bool mFrameWanted = false;
    uint64_t mImageSerial = 0;
    std::chrono::milliseconds mRefineWindow{250}, mRefineSettle{150};
    struct EncodeRequest {
        protocol::ViewSettings view;
        FrameCallback done;
        bool fullQuality = false;
    };
    std::deque<EncodeRequest> mEncodeRequests;
    std::deque<std::tuple<int, int, PickCallback>> mPickRequests;
    std::deque<PickerJob> mPickerJobs;

    // Render thread only.
    std::unique_ptr<Picker> mPicker; // built with the engine, from the same casters (one BVH per session)
    float mSceneRadius = 1.f;        // the casters' bounding radius (an environment reference's ray length)
    Image8 mImage;
    FrameStats mStats;
    uint64_t mImageVersion = ~0ull;
    bool mImagePreview = false;
    uint64_t mFrameNumber = 0;
    // Encodings of the current image by view key (cleared with each new image); other outputs by
    // view key for the current rig version (always full quality: a refinement does not change them).
    std::map<std::string, std::shared_ptr<const EncodedFrame>> mEncoded, mOutputs;
};

} // namespace dfb
