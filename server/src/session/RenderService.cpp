#include "session/RenderService.h"

#include <dfb/protocol/Codec.h>
#include <dfb/server/ImageCodec.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <future>

namespace dfb {

Result<std::unique_ptr<RenderService>> RenderService::start(const DeepBuffer& shot, ShadowGeometry casters,
                                                            Session& session, FrameCallback onFrame, int jpegQuality) {
    std::unique_ptr<RenderService> s(new RenderService(session, std::move(onFrame), jpegQuality));
    std::promise<Status> ready;
    auto fut = ready.get_future();
    s->mThread = std::thread([svc = s.get(), &shot, c = std::move(casters), &ready]() mutable {
        svc->run(&shot, std::move(c), &ready);
    });
    Status st = fut.get();
    if (!st) {
        s->mThread.join();
        return st.error();
    }
    return s;
}

RenderService::~RenderService() {
    {
        std::lock_guard lock(mMutex);
        mStop = true;
    }
    mWake.notify_all();
    if (mThread.joinable()) mThread.join();
}

void RenderService::requestFrame() {
    {
        std::lock_guard lock(mMutex);
        mFrameWanted = true;
    }
    mWake.notify_one();
}

void RenderService::requestOutput(OutputRequest request, OutputCallback done) {
    {
        std::lock_guard lock(mMutex);
        mOutputRequests.emplace_back(std::move(request), std::move(done));
    }
    mWake.notify_one();
}

void RenderService::setRefinement(std::chrono::milliseconds window, std::chrono::milliseconds settle) {
    std::lock_guard lock(mMutex);
    mRefineWindow = window;
    mRefineSettle = settle;
}

std::shared_ptr<const EncodedFrame> RenderService::latestFrame() const {
    std::lock_guard lock(mMutex);
    return mLatest;
}

void RenderService::publish(const Image8& image, uint64_t rigVersion, const FrameStats& stats, bool preview) {
    const auto t0 = std::chrono::steady_clock::now();
    auto jpeg = encodeJpeg(image, mQuality);
    if (!jpeg) {
        std::fprintf(stderr, "dfb-server: %s\n", jpeg.error().toString().c_str());
        return;
    }
    auto msg = std::make_shared<std::vector<uint8_t>>(protocol::FRAME_HEADER_BYTES + jpeg->size());
    protocol::FrameHeader h;
    h.encoding = protocol::Encoding::Jpeg;
    h.frameNumber = ++mFrameNumber;
    h.rigVersion = rigVersion;
    h.width = uint32_t(image.width);
    h.height = uint32_t(image.height);
    protocol::writeFrameHeader(h, msg->data());
    std::copy(jpeg->begin(), jpeg->end(), msg->begin() + protocol::FRAME_HEADER_BYTES);
    auto frame = std::make_shared<EncodedFrame>();
    frame->frameNumber = h.frameNumber;
    frame->rigVersion = rigVersion;
    frame->message = std::move(msg);
    frame->stats = stats;
    frame->preview = preview;
    frame->encodeMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    {
        std::lock_guard lock(mMutex);
        mLatest = frame;
    }
    if (mOnFrame) mOnFrame(frame);
}

void RenderService::run(const DeepBuffer* shot, ShadowGeometry casters, std::promise<Status>* ready) {
    using Clock = std::chrono::steady_clock;
    std::unique_ptr<Engine> engine;
    {
        auto e = Engine::create(*shot, casters);
        if (!e) {
            ready->set_value(e.error());
            return;
        }
        engine = std::move(e.value());
        mDevice = engine->deviceDescription();
        casters = {};
        ready->set_value(okStatus()); // `ready` must not be touched after this
    }
    Image8 image;
    uint64_t imageVersion = ~0ull;
    bool imagePreview = false;
    auto lastNewVersion = Clock::time_point{};
    for (;;) {
        std::deque<std::pair<OutputRequest, OutputCallback>> requests;
        bool refine = false;
        std::chrono::milliseconds window{}, settle{};
        {
            std::unique_lock lock(mMutex);
            window = mRefineWindow;
            settle = mRefineSettle;
            auto wake = [&] { return mStop || mFrameWanted || !mOutputRequests.empty(); };
            if (imagePreview) {
                // A preview is on screen: refine it once edits have stopped for `settle`.
                refine = !mWake.wait_for(lock, settle, wake);
            } else {
                mWake.wait(lock, wake);
            }
            if (mStop) break;
            mFrameWanted = false;
            requests.swap(mOutputRequests);
        }
        engine->setAssetDirectory(mSession.assetDirectory());
        // Keyframed properties take their values at the session's time.
        const Rig rig = protocol::evaluateRig(mSession.rig());
        const bool newVersion = imageVersion != rig.version;
        if (newVersion || (refine && imagePreview)) {
            const auto now = Clock::now();
            // Edits streaming in (a drag): preview quality now, the full frame when they stop.
            const bool preview = newVersion && window.count() > 0 && now - lastNewVersion < window;
            if (newVersion) lastNewVersion = now;
            engine->setPreview(preview);
            FrameStats stats;
            auto r = engine->render(rig, &stats);
            if (!r) {
                std::fprintf(stderr, "dfb-server: render failed: %s\n", r.error().toString().c_str());
                for (auto& req : requests) req.second(r.error(), rig.version);
                imagePreview = false;
                continue;
            }
            image = std::move(r.value());
            imageVersion = rig.version;
            imagePreview = preview;
            publish(image, rig.version, stats, preview);
        }
        for (auto& [request, done] : requests) {
            if ((request.output == "beauty" || request.output.empty()) && request.format != "exr" && !imagePreview) {
                if (auto s = checkOutputRequest(request); !s) {
                    done(s.error(), imageVersion);
                    continue;
                }
                auto bytes = request.format == "png" ? encodePng(image) : encodeJpeg(image, request.jpegQuality);
                if (!bytes) done(bytes.error(), imageVersion);
                else done(EncodedImage{std::move(bytes.value()), request.format == "png" ? "image/png" : "image/jpeg", image.width, image.height}, imageVersion);
                continue;
            }
            // Other outputs (and anything asked for during a drag) at full quality.
            engine->setPreview(false);
            done(renderOutput(*engine, *shot, rig, request), imageVersion);
        }
    }
}

} // namespace dfb
