#include "session/RenderService.h"

#include <dfb/protocol/Codec.h>
#include <dfb/server/ImageCodec.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <future>

namespace dfb {

Result<std::unique_ptr<RenderService>> RenderService::start(const DeepBuffer& shot, ShadowGeometry casters, Session& session,
                                                            ImageCallback onNewImage, Metrics* metrics) {
    std::unique_ptr<RenderService> s(new RenderService(shot, session, std::move(onNewImage), metrics));
    std::promise<Status> ready;
    auto fut = ready.get_future();
    s->mThread = std::thread([svc = s.get(), c = std::move(casters), &ready]() mutable { svc->run(std::move(c), &ready); });
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

void RenderService::requestEncoded(protocol::ViewSettings view, FrameCallback done, bool fullQuality) {
    {
        std::lock_guard lock(mMutex);
        mEncodeRequests.push_back({std::move(view), std::move(done), fullQuality});
    }
    mWake.notify_one();
}

void RenderService::requestPick(int x, int y, PickCallback done) {
    {
        std::lock_guard lock(mMutex);
        mPickRequests.emplace_back(x, y, std::move(done));
    }
    mWake.notify_one();
}

void RenderService::requestPickerJob(PickerJob job) {
    {
        std::lock_guard lock(mMutex);
        mPickerJobs.push_back(std::move(job));
    }
    mWake.notify_one();
}

uint64_t RenderService::imageSerial() const {
    std::lock_guard lock(mMutex);
    return mImageSerial;
}

void RenderService::setRefinement(std::chrono::milliseconds window, std::chrono::milliseconds settle) {
    std::lock_guard lock(mMutex);
    mRefineWindow = window;
    mRefineSettle = settle;
}

Result<std::shared_ptr<const EncodedFrame>> RenderService::encode(Engine& engine, const Rig& rig, const protocol::ViewSettings& view) {
    const std::string key = view.key();
    const bool fast = view.isDefaultImage() && view.encoding != protocol::Encoding::Exr;
    auto& cache = fast ? mEncoded : mOutputs;
    if (auto it = cache.find(key); it != cache.end() && it->second->rigVersion == rig.version) {
        if (fast) return it->second;
        // The same bytes stand for the newer image: a refinement does not change other outputs.
        auto again = std::make_shared<EncodedFrame>(*it->second);
        again->imageSerial = mImageSerial;
        return std::shared_ptr<const EncodedFrame>(again);
    }
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<uint8_t> bytes;
    int width = mImage.width, height = mImage.height;
    if (fast) {
        // The fast path every client starts on: the engine's own 8-bit beauty image.
        auto b = view.encoding == protocol::Encoding::Png ? encodePng(mImage) : encodeJpeg(mImage, view.quality);
        if (!b) return b.error();
        bytes = std::move(b.value());
    } else {
        // This client's exposure and view transform stand in for the rig's (dfb/server/Outputs.h
        // applies the rig's). Always full quality.
        Rig r = rig;
        r.exposureStops = std::clamp(rig.exposureStops + view.exposureStops, -40.f, 40.f);
        if (view.viewTransform == "srgb") r.viewTransform = ViewTransform::Srgb;
        if (view.viewTransform == "filmic") r.viewTransform = ViewTransform::Filmic;
        OutputRequest req;
        req.output = view.output;
        req.format = protocol::encodingName(view.encoding);
        req.jpegQuality = view.quality;
        req.background = view.background;
        engine.setPreview(false);
        ReferenceScene reference;
        reference.assetDir = mSession.assetDirectory();
        if (mPicker) reference = {&mPicker->casters(), mSceneRadius, mSession.assetDirectory()};
        auto out = renderOutput(engine, mShot, r, req, reference);
        if (!out) return out.error();
        bytes = std::move(out->bytes);
        width = out->width;
        height = out->height;
    }
    auto msg = std::make_shared<std::vector<uint8_t>>(protocol::FRAME_HEADER_BYTES + bytes.size());
    protocol::FrameHeader h;
    h.encoding = view.encoding;
    h.frameNumber = ++mFrameNumber;
    h.rigVersion = rig.version;
    h.width = uint32_t(width);
    h.height = uint32_t(height);
    protocol::writeFrameHeader(h, msg->data());
    std::copy(bytes.begin(), bytes.end(), msg->begin() + protocol::FRAME_HEADER_BYTES);
    auto frame = std::make_shared<EncodedFrame>();
    frame->frameNumber = h.frameNumber;
    frame->rigVersion = rig.version;
    frame->imageSerial = mImageSerial;
    frame->preview = fast && mImagePreview;
    frame->encoding = view.encoding;
    frame->message = std::move(msg);
    frame->stats = mStats;
    frame->encodeMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    cache[key] = frame;
    if (mMetrics) mMetrics->frameEncoded(mSession.id());
    return std::shared_ptr<const EncodedFrame>(frame);
}

Result<nlohmann::json> RenderService::pick(Engine& engine, const Rig& rig, int x, int y) {
    if (x < 0 || y < 0 || x >= mShot.width || y >= mShot.height) {
        return makeError(ErrorCode::InvalidValue, "pick: pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                                                      ") is outside the " + std::to_string(mShot.width) + "x" +
                                                      std::to_string(mShot.height) + " image");
    }
    nlohmann::json j{{"x", x}, {"y", y}};
    auto front = mPicker->pick(x, y); // the front covered sample, as drags grab it
    if (!front) {
        j["hit"] = false; // background: nothing was baked there
        j["lights"] = nlohmann::json::array();
        return j;
    }
    const glm::vec3 P = front->P, N = front->N;
    const uint32_t id = front->objectId;
    j["hit"] = true;
    j["position"] = {P.x, P.y, P.z};
    j["normal"] = {N.x, N.y, N.z};
    j["objectId"] = id;
    j["object"] = id >= 1 && id <= mShot.objectNames.size() ? nlohmann::json(mShot.objectNames[id - 1]) : nlohmann::json(nullptr);
    // A light affects the pixel when its contribution there is not zero: cone, facing, light
    // linking and shadow are all accounted for by the engine's own per-light image.
    nlohmann::json lights = nlohmann::json::array();
    for (const Light& l : rig.lights) {
        if (!l.enabled) continue;
        auto img = engine.renderLightLinear(rig, l.name);
        if (!img) return img.error();
        const size_t i = (size_t(y) * size_t(img->width) + size_t(x)) * 4;
        const float r = img->rgba[i], g = img->rgba[i + 1], b = img->rgba[i + 2];
        if (r + g + b > 0.f) lights.push_back({{"name", l.name}, {"radiance", {r, g, b}}});
    }
    j["lights"] = lights;
    protocol::shortestFloats(j); // positions and radiance are floats: their shortest digits
    return j;
}

void RenderService::run(ShadowGeometry casters, std::promise<Status>* ready) {
    std::unique_ptr<Engine> engine;
    {
        auto e = Engine::create(mShot, casters);
        if (!e) {
            ready->set_value(e.error());
            return;
        }
        engine = std::move(e.value());
        engine->setAssetDirectory(mSession.assetDirectory()); // set before start, fixed for the server's life
        mDevice = engine->deviceDescription();
        // The picker's hierarchy of the same casters, built once (issue 17 point 1).
        auto p = Picker::create(mShot, casters);
        if (!p) {
            ready->set_value(p.error());
            return;
        }
        mPicker = std::move(p.value());
        glm::vec3 lo(1e30f), hi(-1e30f);
        for (const glm::vec3& v : casters.positions) lo = glm::min(lo, v), hi = glm::max(hi, v);
        mSceneRadius = casters.positions.empty() ? 1.f : std::max(0.5f * glm::length(hi - lo), 1e-3f);
        casters = {};
        ready->set_value(okStatus()); // `ready` must not be touched after this
    }
    using Clock = std::chrono::steady_clock;
    auto lastNewVersion = Clock::time_point{};
    for (;;) {
        std::deque<EncodeRequest> encodes;
        std::deque<std::tuple<int, int, PickCallback>> picks;
        std::deque<PickerJob> jobs;
        bool refine = false;
        std::chrono::milliseconds window{}, settle{};
        {
            std::unique_lock lock(mMutex);
            window = mRefineWindow;
            settle = mRefineSettle;
            auto wake = [&] { return mStop || mFrameWanted || !mEncodeRequests.empty() || !mPickRequests.empty() ||
                               !mPickerJobs.empty(); };
            if (mImagePreview) {
                // A preview is on screen: refine it once changes have stopped for `settle`.
                refine = !mWake.wait_for(lock, settle, wake);
            } else {
                mWake.wait(lock, wake);
            }
            if (mStop) break;
            mFrameWanted = false;
            encodes.swap(mEncodeRequests);
            picks.swap(mPickRequests);
            jobs.swap(mPickerJobs);
        }
        // Keyframed properties take their values at the session's time.
        const Rig rig = protocol::evaluateRig(mSession.rig());
        const bool newVersion = mImageVersion != rig.version;
        // Someone needs the real image now: refine at once instead of after `settle`.
        const bool fullNow = std::any_of(encodes.begin(), encodes.end(), [](const EncodeRequest& r) { return r.fullQuality; });
        if (newVersion || ((refine || fullNow) && mImagePreview)) {
            const auto now = Clock::now();
            // Changes streaming in (a drag): preview quality now, the full frame when they stop.
            const bool preview = newVersion && !fullNow && window.count() > 0 && now - lastNewVersion < window;
            if (newVersion) lastNewVersion = now;
            engine->setPreview(preview);
            FrameStats stats;
            auto r = engine->render(rig, &stats);
            if (!r) {
                std::fprintf(stderr, "dfb-server: session %s: render failed: %s\n", mSession.id().c_str(), r.error().toString().c_str());
                for (auto& req : encodes) req.done(r.error());
                for (auto& req : picks) std::get<2>(req)(r.error());
                for (auto& job : jobs) job(*mPicker, mShot); // they do not need the image
                mImagePreview = false;
                continue;
            }
            mImage = std::move(r.value());
            mStats = stats;
            mImageVersion = rig.version;
            mImagePreview = preview;
            mEncoded.clear();
            if (newVersion) mOutputs.clear();
            uint64_t serial = 0;
            {
                std::lock_guard lock(mMutex);
                serial = ++mImageSerial;
            }
            if (mMetrics && newVersion) mMetrics->frameRendered(mSession.id(), rig.version);
            if (mOnNewImage) mOnNewImage(rig.version, serial);
        }
        for (auto& req : encodes) req.done(encode(*engine, rig, req.view));
        if (!picks.empty()) engine->setPreview(false);
        for (auto& [x, y, cb] : picks) cb(pick(*engine, rig, x, y));
        for (auto& job : jobs) job(*mPicker, mShot);
    }
}

} // namespace dfb
