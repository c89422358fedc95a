#include "session/RenderService.h"

#include <dfb/protocol/Codec.h>
#include <dfb/server/ImageCodec.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <future>

namespace dfb {
namespace {

float srgbEncode(float c) {
    c = std::clamp(c, 0.f, 1.f);
    return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.f / 2.4f) - 0.055f;
}

// The non-beauty outputs, tone-mapped on the CPU (they are requested rarely).
Result<Image8> renderOutput(Engine& engine, const Rig& rig, const std::string& output) {
    const size_t colon = output.find(':');
    const std::string kind = output.substr(0, colon), name = colon == std::string::npos ? "" : output.substr(colon + 1);
    if ((kind != "light" && kind != "shadow") || name.empty()) {
        return makeError(ErrorCode::InvalidValue, "unknown output '" + output + "' (beauty, light:NAME, shadow:NAME)");
    }
    auto linear = kind == "light" ? engine.renderLightLinear(rig, name) : engine.renderShadowMask(rig, name);
    if (!linear) return linear.error();
    Image8 img;
    img.width = linear->width;
    img.height = linear->height;
    img.rgba.resize(linear->rgba.size());
    const float exposure = std::exp2(rig.exposureStops);
    for (size_t i = 0; i < linear->rgba.size(); i += 4) {
        for (int c = 0; c < 3; ++c) {
            const float v = kind == "light" ? srgbEncode(linear->rgba[i + size_t(c)] * exposure)
                                            : std::clamp(linear->rgba[i], 0.f, 1.f); // grey visibility
            img.rgba[i + size_t(c)] = uint8_t(std::lround(v * 255.f));
        }
        img.rgba[i + 3] = 255;
    }
    return img;
}

} // namespace

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

void RenderService::requestImage(ImageCallback done, std::string output) {
    {
        std::lock_guard lock(mMutex);
        mImageRequests.emplace_back(std::move(done), std::move(output));
    }
    mWake.notify_one();
}

std::shared_ptr<const EncodedFrame> RenderService::latestFrame() const {
    std::lock_guard lock(mMutex);
    return mLatest;
}

void RenderService::run(const DeepBuffer* shot, ShadowGeometry casters, std::promise<Status>* ready) {
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
        ready->set_value(okStatus()); // `shot` and `ready` must not be touched after this
    }
    Image8 image;
    uint64_t imageVersion = ~0ull;
    uint64_t frameNumber = 0;
    for (;;) {
        bool wantFrame = false;
        std::deque<std::pair<ImageCallback, std::string>> requests;
        {
            std::unique_lock lock(mMutex);
            mWake.wait(lock, [&] { return mStop || mFrameWanted || !mImageRequests.empty(); });
            if (mStop) break;
            wantFrame = std::exchange(mFrameWanted, false);
            requests.swap(mImageRequests);
        }
        // Keyframed properties take their values at the session's time.
        const Rig rig = protocol::evaluateRig(mSession.rig());
        if (imageVersion != rig.version) {
            FrameStats stats;
            auto r = engine->render(rig, &stats);
            if (!r) {
                std::fprintf(stderr, "dfb-server: render failed: %s\n", r.error().toString().c_str());
                for (auto& req : requests) req.first(r.error(), rig.version);
                continue;
            }
            image = std::move(r.value());
            imageVersion = rig.version;
            wantFrame = true;
            const auto t0 = std::chrono::steady_clock::now();
            auto jpeg = encodeJpeg(image, mQuality);
            if (!jpeg) {
                std::fprintf(stderr, "dfb-server: %s\n", jpeg.error().toString().c_str());
                continue;
            }
            auto msg = std::make_shared<std::vector<uint8_t>>(protocol::FRAME_HEADER_BYTES + jpeg->size());
            protocol::FrameHeader h;
            h.encoding = protocol::Encoding::Jpeg;
            h.frameNumber = ++frameNumber;
            h.rigVersion = rig.version;
            h.width = uint32_t(image.width);
            h.height = uint32_t(image.height);
            protocol::writeFrameHeader(h, msg->data());
            std::copy(jpeg->begin(), jpeg->end(), msg->begin() + protocol::FRAME_HEADER_BYTES);
            auto frame = std::make_shared<EncodedFrame>();
            frame->frameNumber = h.frameNumber;
            frame->rigVersion = rig.version;
            frame->message = std::move(msg);
            frame->stats = stats;
            frame->encodeMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
            {
                std::lock_guard lock(mMutex);
                mLatest = frame;
            }
            if (mOnFrame) mOnFrame(frame);
        } else if (wantFrame) {
            // Nothing changed since the last frame (for example an edit that was refused).
        }
        for (auto& [cb, output] : requests) {
            if (output == "beauty" || output.empty()) {
                cb(image, imageVersion);
            } else {
                cb(renderOutput(*engine, rig, output), imageVersion);
            }
        }
    }
}

} // namespace dfb
