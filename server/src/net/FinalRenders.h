#pragma once
// A session's final renders (issue 19 point 8, docs/protocol.md "Final render"): the shot with
// the rig of the moment rendered in Cycles by Debian's Blender, headless, as a child process
// (server/blender/dfb_final.py, from the job dfb/server/FinalRender.h writes). One render at a
// time per session: a request for the version being rendered joins it (two editors asking at once
// get one render), the last finished one is kept for its rig version. Progress ("Sample N/M" from
// Cycles' status lines) goes to every client of the session as `final` messages. The child is
// killed at the time limit, on cancel and when the server exits (PR_SET_PDEATHSIG), and its
// folder removed. I/O thread only.
#include "net/Beast.h"

#include <dfb/core/Result.h>
#include <dfb/gbuffer/DeepBuffer.h>
#include <dfb/protocol/Rig.h>
#include <dfb/server/Engine.h>
#include <dfb/server/FinalRender.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace dfb::net {

struct FinalRenderLimits {
    std::chrono::seconds timeLimit{600};      ///< --final-timeout
    std::string blender = "blender";          ///< --blender: the executable (searched in PATH)
    int maxSamples = 4096;
};

class FinalRenders {
public:
    enum class State { None, Exporting, Running, Done, Failed, Cancelled };
    /// Exports the scene with `rig` (the caller's job: exportGltf on the render thread) and calls
    /// back with the GLB bytes or the error.
    using Exporter = std::function<void(const Rig& rig, std::function<void(Result<std::string>)> done)>;
    /// Every change of state and every progress step, as the `final` message's JSON.
    using Notify = std::function<void(const nlohmann::json& message)>;

    FinalRenders(asio::io_context& ioc, const DeepBuffer& shot, Exporter exporter, Notify notify);
    ~FinalRenders();

    void setLimits(FinalRenderLimits limits) { mLimits = std::move(limits); }
    /// Starts a render of `rig` (its version) or joins the one of that version and options running
    /// or done. Refused with Conflict while a render of another version runs; InvalidValue for
    /// samples outside 1..maxSamples.
    Result<nlohmann::json> start(const Rig& rig, const FinalRenderOptions& options, const std::string& assetDirectory);
    /// Stops a running render (the child is killed); MissingData when none runs.
    Result<nlohmann::json> cancel();
    /// The state as the `final` message has it.
    nlohmann::json status() const;
    /// A render is being exported or run (the session is not idle).
    bool busy() const { return mState == State::Exporting || mState == State::Running; }
    /// The finished image encoded as EXR (linear, times the rig's exposure: as the beauty's EXR)
    /// or PNG (the rig's view transform), encoded once per render; null when none is done. A PNG
    /// in a viewer's own view (extra stops, another transform: what the browser compares with its
    /// live frames) is encoded per request and not kept.
    Result<std::shared_ptr<const std::string>> encoded(bool exr, float extraStops = 0.f,
                                                       std::optional<ViewTransform> viewTransform = std::nullopt);
    /// The rig version of the finished image.
    uint64_t imageVersion() const { return mRig.version; }

private:
    struct Child;
    void spawn(const std::string& glb);
    void readLine();
    void finish(State state, const std::string& error);

    asio::io_context& mIoc;
    const DeepBuffer& mShot;
    Exporter mExporter;
    Notify mNotify;
    FinalRenderLimits mLimits;

    State mState = State::None;
    uint64_t mGeneration = 0; ///< bumps per render: callbacks of an older one are ignored
    Rig mRig;
    FinalRenderOptions mOptions;
    std::string mAssetDirectory;
    std::string mFolder;
    int mSamplesDone = 0, mSamplesTotal = 0;
    std::vector<std::string> mNotes;
    std::string mError;
    std::string mLastLines; ///< the child's last output lines, for an error without DFB_ERROR
    std::chrono::steady_clock::time_point mStarted;
    double mSeconds = 0;
    std::shared_ptr<const ImageF> mImage;
    std::shared_ptr<const std::string> mExr, mPng; ///< mImage encoded, when asked for
    std::unique_ptr<Child> mChild;
};

} // namespace dfb::net
