#include "session/FrameEncoder.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfOutputFile.h>

#include <algorithm>
#include <cmath>
#include <cstring>

namespace dfb {
namespace {

float srgbEncode(float c) {
    c = std::clamp(c, 0.f, 1.f);
    return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.f / 2.4f) - 0.055f;
}

// OpenEXR writes through an OStream; this one grows a byte vector (no temporary file).
class MemoryStream : public Imf::OStream {
public:
    MemoryStream() : Imf::OStream("memory") {}
    void write(const char c[], int n) override {
        if (mPos + size_t(n) > mData.size()) mData.resize(mPos + size_t(n));
        std::memcpy(mData.data() + mPos, c, size_t(n));
        mPos += size_t(n);
    }
    uint64_t tellp() override { return mPos; }
    void seekp(uint64_t pos) override { mPos = size_t(pos); }
    std::vector<uint8_t> mData;
    size_t mPos = 0;
};

} // namespace

Image8 toDisplay(const ImageF& linear, float exposureStops, const std::string& viewTransform, bool grey) {
    Image8 img;
    img.width = linear.width;
    img.height = linear.height;
    img.rgba.resize(linear.rgba.size());
    const float scale = std::exp2(exposureStops);
    const bool srgb = viewTransform != "linear";
    for (size_t i = 0; i + 3 < linear.rgba.size(); i += 4) {
        for (size_t c = 0; c < 3; ++c) {
            const float x = (grey ? linear.rgba[i] : linear.rgba[i + c]) * scale;
            const float v = srgb ? srgbEncode(x) : std::clamp(x, 0.f, 1.f);
            img.rgba[i + c] = uint8_t(std::lround(v * 255.f));
        }
        img.rgba[i + 3] = 255;
    }
    return img;
}

Result<std::vector<uint8_t>> encodeExr(const ImageF& linear, float exposureStops) {
    if (linear.width <= 0 || linear.height <= 0 || linear.rgba.size() != size_t(linear.width) * size_t(linear.height) * 4) {
        return makeError(ErrorCode::InvalidValue, "EXR encoding: empty or inconsistent image");
    }
    std::vector<float> px = linear.rgba;
    const float scale = std::exp2(exposureStops);
    if (scale != 1.f) {
        for (size_t i = 0; i < px.size(); ++i) {
            if (i % 4 != 3) px[i] *= scale;
        }
    }
    try {
        MemoryStream stream;
        Imf::Header header(linear.width, linear.height);
        header.compression() = Imf::ZIP_COMPRESSION;
        Imf::FrameBuffer fb;
        const char* names[] = {"R", "G", "B", "A"};
        for (size_t c = 0; c < 4; ++c) {
            header.channels().insert(names[c], Imf::Channel(Imf::FLOAT));
            fb.insert(names[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(px.data() + c), 4 * sizeof(float),
                                           4 * sizeof(float) * size_t(linear.width)));
        }
        {
            Imf::OutputFile file(stream, header);
            file.setFrameBuffer(fb);
            file.writePixels(linear.height);
        }
        return std::move(stream.mData);
    } catch (const std::exception& e) {
        return makeError(ErrorCode::IoError, std::string("EXR encoding: ") + e.what());
    }
}

} // namespace dfb
