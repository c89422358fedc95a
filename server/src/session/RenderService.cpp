#include "session/RenderService.h"

#include "session/FrameEncoder.h"

#include <dfb/protocol/Codec.h>
#include <dfb/server/ImageCodec.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <future>

namespace dfb {

Result<std::unique_ptr<RenderService>> RenderService::start(const DeepBuffer& shot, ShadowGeometry casters, Session& session,
                                                            VersionCallback onNewVersion, Metrics* metrics) {
    std::unique_ptr<RenderService> s(new RenderService(shot, session, std::move(onNewVersion), metrics));
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

void RenderService::requestEncoded(protocol::ViewSettings view, FrameCallback done) {
    {
        std::lock_guard lock(mMutex);
        mEncodeRequests.emplace_back(std::move(view), std::move(done));
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

uint64_t RenderService::renderedVersion() const {
    std::lock_guard lock(mMutex);
    return mRenderedVersion;
}

Result<std::shared_ptr<const EncodedFrame>> RenderService::encode(Engine& engine, const Rig& rig, const protocol::ViewSettings& view) {
    const std::string key = view.key();
    if (auto it = mEncoded.find(key); it != mEncoded.end()) return it->second;
    const auto t0 = std::chrono::steady_clock::now();
    Result<std::vector<uint8_t>> bytes = std::vector<uint8_t>{};
    int width = mImage.width, height = mImage.height;
    if (view.isDefaultImage() && view.encoding != protocol::Encoding::Exr) {
        // The fast path every client starts on: the engine's own 8-bit beauty image.
        bytes = view.encoding == protocol::Encoding::Png ? encodePng(mImage) : encodeJpeg(mImage, view.quality);
    } else {
        const size_t colon = view.output.find(':');
        const std::string kind = view.output.substr(0, colon), name = colon == std::string::npos ? "" : view.output.substr(colon + 1);
        Result<ImageF> linear = ImageF{};
        if (kind == "beauty") linear = engine.renderLinear(rig);
        else if (kind == "light") linear = engine.renderLightLinear(rig, name);
        else if (kind == "shadow") linear = engine.renderShadowMask(rig, name);
        else return makeError(ErrorCode::MissingData, "output '" + view.output + "': G-buffer layer outputs are not available in this server");
        if (!linear) return linear.error();
        width = linear->width;
        height = linear->height;
        // Masks are data, not light: no exposure. Light outputs get the rig's and the view's.
        const bool mask = kind == "shadow";
        const float stops = mask ? 0.f : rig.exposureStops + view.exposureStops;
        if (view.encoding == protocol::Encoding::Exr) {
            bytes = encodeExr(linear.value(), stops);
        } else {
            const Image8 img = toDisplay(linear.value(), stops, mask ? "linear" : view.viewTransform, mask);
            bytes = view.encoding == protocol::Encoding::Png ? encodePng(img) : encodeJpeg(img, view.quality);
        }
    }
    if (!bytes) return bytes.error();
    auto msg = std::make_shared<std::vector<uint8_t>>(protocol::FRAME_HEADER_BYTES + bytes->size());
    protocol::FrameHeader h;
    h.encoding = view.encoding;
    h.frameNumber = ++mFrameNumber;
    h.rigVersion = rig.version;
    h.width = uint32_t(width);
    h.height = uint32_t(height);
    protocol::writeFrameHeader(h, msg->data());
    std::copy(bytes->begin(), bytes->end(), msg->begin() + protocol::FRAME_HEADER_BYTES);
    auto frame = std::make_shared<EncodedFrame>();
    frame->frameNumber = h.frameNumber;
    frame->rigVersion = rig.version;
    frame->encoding = view.encoding;
    frame->message = std::move(msg);
    frame->stats = mStats;
    frame->encodeMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    mEncoded[key] = frame;
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
    const size_t p = size_t(y) * size_t(mShot.width) + size_t(x);
    if (mShot.sampleOffset[p] == mShot.sampleOffset[p + 1]) {
        j["hit"] = false; // background: nothing was baked there
        j["lights"] = nlohmann::json::array();
        return j;
    }
    const size_t s = mShot.firstSample(x, y);
    const glm::vec3 P = mShot.position(s), N = mShot.normal(s);
    const uint32_t id = s < mShot.objectId.size() ? mShot.objectId[s] : 0;
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
        mDevice = engine->deviceDescription();
        casters = {};
        ready->set_value(okStatus()); // `ready` must not be touched after this
    }
    for (;;) {
        std::deque<std::pair<protocol::ViewSettings, FrameCallback>> encodes;
        std::deque<std::tuple<int, int, PickCallback>> picks;
        {
            std::unique_lock lock(mMutex);
            mWake.wait(lock, [&] { return mStop || mFrameWanted || !mEncodeRequests.empty() || !mPickRequests.empty(); });
            if (mStop) break;
            mFrameWanted = false;
            encodes.swap(mEncodeRequests);
            picks.swap(mPickRequests);
        }
        // Keyframed properties take their values at the session's time.
        const Rig rig = protocol::evaluateRig(mSession.rig());
        if (mImageVersion != rig.version) {
            FrameStats stats;
            auto r = engine->render(rig, &stats);
            if (!r) {
                std::fprintf(stderr, "dfb-server: session %s: render failed: %s\n", mSession.id().c_str(), r.error().toString().c_str());
                for (auto& req : encodes) req.second(r.error());
                for (auto& req : picks) std::get<2>(req)(r.error());
                continue;
            }
            mImage = std::move(r.value());
            mStats = stats;
            mImageVersion = rig.version;
            mEncoded.clear();
            {
                std::lock_guard lock(mMutex);
                mRenderedVersion = rig.version;
            }
            if (mMetrics) mMetrics->frameRendered(mSession.id(), rig.version);
            if (mOnNewVersion) mOnNewVersion(rig.version);
        }
        for (auto& [view, cb] : encodes) cb(encode(*engine, rig, view));
        for (auto& [x, y, cb] : picks) cb(pick(*engine, rig, x, y));
    }
}

} // namespace dfb
