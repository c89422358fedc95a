#include <dfb/server/ImageCodec.h>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <turbojpeg.h>

#include "WorkerPool.h"

#include <algorithm>
#include <cmath>
#include <thread>

namespace dfb {

namespace {

// One JPEG of `rows` rows of `image` from row `first` (libjpeg-turbo: 4:2:0, fast integer DCT).
Result<std::vector<uint8_t>> compressRows(const Image8& image, int first, int rows, int quality) {
    tjhandle tj = tjInitCompress();
    if (!tj) return makeError(ErrorCode::IoError, std::string("tjInitCompress: ") + tjGetErrorStr());
    unsigned char* out = nullptr;
    unsigned long size = 0;
    const int rc = tjCompress2(tj, image.rgba.data() + size_t(first) * size_t(image.width) * 4, image.width, image.width * 4,
                               rows, TJPF_RGBA, &out, &size, TJSAMP_420, std::clamp(quality, 1, 100), TJFLAG_FASTDCT);
    if (rc != 0) {
        std::string msg = tjGetErrorStr2(tj);
        tjDestroy(tj);
        if (out) tjFree(out);
        return makeError(ErrorCode::IoError, "JPEG encoding failed: " + msg);
    }
    std::vector<uint8_t> bytes(out, out + size);
    tjFree(out);
    tjDestroy(tj);
    return bytes;
}

// Offset of the first byte after the marker segment `code` (0xFFcode, big-endian length), or 0.
size_t segmentEnd(const std::vector<uint8_t>& j, uint8_t code, size_t* start = nullptr) {
    for (size_t i = 2; i + 4 <= j.size();) {
        if (j[i] != 0xFF) return 0;
        const size_t len = size_t(j[i + 2]) << 8 | j[i + 3];
        if (j[i + 1] == code) {
            if (start) *start = i;
            return i + 2 + len;
        }
        if (j[i + 1] == 0xDA) return 0; // scan data follows: no more headers
        i += 2 + len;
    }
    return 0;
}

} // namespace

// Large images are cut into strips of whole MCU rows (16 rows at 4:2:0) that are encoded on
// several threads and joined into one baseline JPEG with restart markers (ITU-T T.81, B.2.4.4):
// every strip is encoded alone with the same tables, so its entropy-coded data starts with the DC
// predictions reset and ends byte-aligned, exactly what follows a restart marker. The file takes
// strip 0's headers with the full height and a restart interval of one strip's MCUs (DRI), then the
// strips' scan data separated by RST0..RST7, then EOI. Every 8x8 block is coded as in a
// single-threaded encoding, so the decoded pixels are the same.
Result<std::vector<uint8_t>> encodeJpeg(const Image8& image, int quality, int threadCount) {
    if (image.width <= 0 || image.height <= 0) return makeError(ErrorCode::InvalidValue, "encodeJpeg: empty image");
    const int mcuColumns = (image.width + 15) / 16;
    const int threads = threadCount > 0 ? threadCount : int(std::min<unsigned>(std::max(1u, std::thread::hardware_concurrency()), 16u));
    // Strips of at least 64 rows, and a restart interval within the 16-bit DRI field.
    int stripMcuRows = std::max(4, ((image.height + 15) / 16 + threads - 1) / threads);
    stripMcuRows = std::min(stripMcuRows, 65535 / mcuColumns);
    const int stripRows = stripMcuRows * 16;
    const int strips = (image.height + stripRows - 1) / stripRows;
    if (strips <= 1 || stripMcuRows < 1) return compressRows(image, 0, image.height, quality);

    std::vector<Result<std::vector<uint8_t>>> parts(size_t(strips), std::vector<uint8_t>{});
    WorkerPool::shared().run(strips, [&](int i) {
        parts[size_t(i)] = compressRows(image, i * stripRows, std::min(stripRows, image.height - i * stripRows), quality);
    });
    for (const auto& p : parts)
        if (!p) return p.error();

    const std::vector<uint8_t>& head = parts[0].value();
    size_t sofStart = 0;
    const size_t sofEnd = segmentEnd(head, 0xC0, &sofStart); // baseline SOF0
    size_t sosStart = 0;
    const size_t headerEnd = segmentEnd(head, 0xDA, &sosStart);
    if (!sofEnd || !headerEnd) return compressRows(image, 0, image.height, quality); // unexpected layout: no strips
    std::vector<uint8_t> out(head.begin(), head.begin() + std::ptrdiff_t(sosStart));
    out[sofStart + 5] = uint8_t(image.height >> 8); // SOF0: P, Y (height), X, ...
    out[sofStart + 6] = uint8_t(image.height & 0xFF);
    const int interval = mcuColumns * stripMcuRows;
    const uint8_t dri[6] = {0xFF, 0xDD, 0x00, 0x04, uint8_t(interval >> 8), uint8_t(interval & 0xFF)};
    out.insert(out.end(), dri, dri + 6);
    out.insert(out.end(), head.begin() + std::ptrdiff_t(sosStart), head.begin() + std::ptrdiff_t(headerEnd));
    for (int i = 0; i < strips; ++i) {
        const std::vector<uint8_t>& j = parts[size_t(i)].value();
        const size_t dataStart = segmentEnd(j, 0xDA);
        if (!dataStart || j.size() < dataStart + 2 || j[j.size() - 2] != 0xFF || j[j.size() - 1] != 0xD9) {
            return makeError(ErrorCode::IoError, "JPEG encoding: unexpected strip layout");
        }
        out.insert(out.end(), j.begin() + std::ptrdiff_t(dataStart), j.end() - 2);
        if (i + 1 < strips) {
            out.push_back(0xFF);
            out.push_back(uint8_t(0xD0 + i % 8));
        }
    }
    out.push_back(0xFF);
    out.push_back(0xD9);
    return out;
}

Result<std::vector<uint8_t>> jpegThumbnail(const uint8_t* jpeg, size_t size, int maxWidth, int quality) {
    if (!jpeg || size == 0 || size > (size_t(1) << 31)) return makeError(ErrorCode::InvalidValue, "thumbnail: no JPEG data");
    tjhandle tj = tjInitDecompress();
    if (!tj) return makeError(ErrorCode::IoError, std::string("tjInitDecompress: ") + tjGetErrorStr());
    int w = 0, h = 0, subsamp = 0, colorspace = 0;
    if (tjDecompressHeader3(tj, jpeg, (unsigned long)size, &w, &h, &subsamp, &colorspace) != 0 || w <= 0 || h <= 0) {
        const std::string msg = tjGetErrorStr2(tj);
        tjDestroy(tj);
        return makeError(ErrorCode::InvalidValue, "thumbnail: not a JPEG: " + msg);
    }
    // The scaling factors libjpeg-turbo decodes directly (the IDCT at a smaller size: no separate
    // resampling pass); the largest whose width fits, else the smallest there is.
    int count = 0;
    tjscalingfactor* factors = tjGetScalingFactors(&count);
    int tw = 0, th = 0, smallest = -1;
    for (int i = 0; i < count; ++i) {
        const int sw = TJSCALED(w, factors[i]), sh = TJSCALED(h, factors[i]);
        if (sw <= maxWidth && sw > tw) tw = sw, th = sh;
        if (smallest < 0 || sw < TJSCALED(w, factors[smallest])) smallest = i;
    }
    if (tw == 0) tw = TJSCALED(w, factors[smallest]), th = TJSCALED(h, factors[smallest]);
    Image8 small;
    small.width = tw;
    small.height = th;
    small.rgba.resize(size_t(tw) * size_t(th) * 4);
    const int rc = tjDecompress2(tj, jpeg, (unsigned long)size, small.rgba.data(), tw, tw * 4, th, TJPF_RGBA, TJFLAG_FASTDCT);
    const std::string msg = rc != 0 ? tjGetErrorStr2(tj) : "";
    tjDestroy(tj);
    if (rc != 0) return makeError(ErrorCode::InvalidValue, "thumbnail: cannot decode the JPEG: " + msg);
    return encodeJpeg(small, quality, 1);
}

Result<std::vector<uint8_t>> encodePng(const Image8& image) {
    if (image.width <= 0 || image.height <= 0) return makeError(ErrorCode::InvalidValue, "encodePng: empty image");
    std::vector<unsigned char> bytes;
    OIIO::Filesystem::IOVecOutput proxy(bytes);
    auto out = OIIO::ImageOutput::create("out.png");
    if (!out) return makeError(ErrorCode::IoError, "OpenImageIO has no PNG writer: " + OIIO::geterror());
    OIIO::ImageSpec spec(image.width, image.height, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("png:compressionLevel", 3); // fast: frames are written often, rarely kept
    if (!out->set_ioproxy(&proxy) || !out->open("out.png", spec)) {
        return makeError(ErrorCode::IoError, "PNG encoding failed: " + out->geterror());
    }
    // Write RGB out of RGBA by striding over the alpha byte.
    if (!out->write_image(OIIO::TypeDesc::UINT8, image.rgba.data(), 4, OIIO::AutoStride, OIIO::AutoStride) ||
        !out->close()) {
        return makeError(ErrorCode::IoError, "PNG encoding failed: " + out->geterror());
    }
    return std::vector<uint8_t>(bytes.begin(), bytes.end());
}

Result<std::vector<uint8_t>> encodeExr(const std::vector<NamedImageF>& layers) {
    if (layers.empty() || layers[0].image.width <= 0 || layers[0].image.height <= 0) {
        return makeError(ErrorCode::InvalidValue, "encodeExr: no image");
    }
    const int w = layers[0].image.width, h = layers[0].image.height;
    std::vector<std::string> names;
    for (const NamedImageF& l : layers) {
        if (l.image.width != w || l.image.height != h || l.image.rgba.size() != size_t(w) * size_t(h) * 4) {
            return makeError(ErrorCode::InvalidValue, "encodeExr: layer '" + l.name + "' differs in size");
        }
        const std::string prefix = l.name.empty() ? "" : l.name + ".";
        for (const char* c : {"R", "G", "B"}) names.push_back(prefix + c);
        if (l.name.empty()) names.push_back("A");
    }
    const int nch = int(names.size());
    OIIO::ImageSpec spec(w, h, nch, OIIO::TypeDesc::FLOAT);
    spec.channelnames = names;
    spec.alpha_channel = -1;
    for (int i = 0; i < nch; ++i)
        if (names[size_t(i)] == "A") spec.alpha_channel = i;
    spec.attribute("compression", "zip");
    // Interleave the layers' pixels into one scanline buffer.
    std::vector<float> pixels(size_t(w) * size_t(h) * size_t(nch));
    size_t ch = 0;
    for (const NamedImageF& l : layers) {
        const int n = l.name.empty() ? 4 : 3;
        for (size_t p = 0; p < size_t(w) * size_t(h); ++p)
            for (int c = 0; c < n; ++c) pixels[p * size_t(nch) + ch + size_t(c)] = l.image.rgba[p * 4 + size_t(c)];
        ch += size_t(n);
    }
    std::vector<unsigned char> bytes;
    OIIO::Filesystem::IOVecOutput proxy(bytes);
    auto out = OIIO::ImageOutput::create("out.exr");
    if (!out) return makeError(ErrorCode::IoError, "OpenImageIO has no EXR writer: " + OIIO::geterror());
    if (!out->set_ioproxy(&proxy) || !out->open("out.exr", spec) ||
        !out->write_image(OIIO::TypeDesc::FLOAT, pixels.data()) || !out->close()) {
        return makeError(ErrorCode::IoError, "EXR encoding failed: " + out->geterror());
    }
    return std::vector<uint8_t>(bytes.begin(), bytes.end());
}

namespace {

// Opens an image and checks its header: the one place that decides what the engine accepts.
Result<std::unique_ptr<OIIO::ImageInput>> openImage(const std::string& path) {
    auto in = OIIO::ImageInput::open(path);
    if (!in) return makeError(ErrorCode::IoError, "cannot read image '" + path + "': " + OIIO::geterror());
    const OIIO::ImageSpec& spec = in->spec();
    constexpr int MAX_SIDE = 16384;
    if (spec.width <= 0 || spec.height <= 0 || spec.width > MAX_SIDE || spec.height > MAX_SIDE || spec.nchannels <= 0) {
        return makeError(ErrorCode::InvalidValue, "image '" + path + "' has an unsupported size " +
                                                      std::to_string(spec.width) + "x" + std::to_string(spec.height));
    }
    return in;
}

// Float-coded files hold linear values (radiance in an HDR map); integer ones are display-coded.
bool isFloatData(const OIIO::ImageSpec& spec) {
    const auto base = spec.format.basetype;
    return base == OIIO::TypeDesc::HALF || base == OIIO::TypeDesc::FLOAT || base == OIIO::TypeDesc::DOUBLE;
}

// Every channel of every pixel as float, row 0 at the top.
Result<std::vector<float>> readChannels(OIIO::ImageInput& in, const std::string& path) {
    const OIIO::ImageSpec& spec = in.spec();
    std::vector<float> src(size_t(spec.width) * size_t(spec.height) * size_t(spec.nchannels));
    if (!in.read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, src.data())) {
        return makeError(ErrorCode::IoError, "cannot read image '" + path + "': " + in.geterror());
    }
    return src;
}

} // namespace

Status checkImageFile(const std::string& path) {
    auto in = openImage(path);
    return in ? okStatus() : Status(in.error());
}

Result<ImageF> readLinearImage(const std::string& path) {
    auto opened = openImage(path);
    if (!opened) return opened.error();
    auto& in = opened.value();
    const OIIO::ImageSpec spec = in->spec();
    auto read = readChannels(*in, path);
    if (!read) return read.error();
    const std::vector<float>& src = read.value();
    const bool srgb = !isFloatData(spec);
    auto decode = [srgb](float v) {
        if (!std::isfinite(v)) return 0.f;
        if (!srgb) return std::max(v, 0.f);
        v = std::clamp(v, 0.f, 1.f);
        return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
    };
    ImageF img;
    img.width = spec.width;
    img.height = spec.height;
    img.rgba.resize(size_t(spec.width) * size_t(spec.height) * 4);
    const size_t n = size_t(spec.nchannels);
    for (size_t p = 0; p < size_t(spec.width) * size_t(spec.height); ++p) {
        const float* s = &src[p * n];
        const float r = decode(s[0]), g = n >= 3 ? decode(s[1]) : r, b = n >= 3 ? decode(s[2]) : r;
        img.rgba[p * 4] = r;
        img.rgba[p * 4 + 1] = g;
        img.rgba[p * 4 + 2] = b;
        img.rgba[p * 4 + 3] = n == 2 ? s[1] : n >= 4 ? s[3] : 1.f;
    }
    return img;
}

namespace {

// The header checks of an environment map: float data within the size limit.
Result<std::unique_ptr<OIIO::ImageInput>> openHdrImage(const std::string& path, int maxWidth, int maxHeight) {
    auto opened = openImage(path);
    if (!opened) return opened.error();
    const OIIO::ImageSpec& spec = opened.value()->spec();
    if (!isFloatData(spec)) {
        return makeError(ErrorCode::InvalidValue, "image '" + path + "' holds " + std::string(spec.format.c_str()) +
                                                      " data, not float: an environment map must be HDR (OpenEXR or Radiance .hdr)");
    }
    if (spec.width > maxWidth || spec.height > maxHeight) {
        return makeError(ErrorCode::InvalidValue, "image '" + path + "' is " + std::to_string(spec.width) + "x" +
                                                      std::to_string(spec.height) + " texels; an environment map may have at most " +
                                                      std::to_string(maxWidth) + "x" + std::to_string(maxHeight));
    }
    return opened;
}

} // namespace

Status checkHdrImageFile(const std::string& path, int maxWidth, int maxHeight) {
    auto in = openHdrImage(path, maxWidth, maxHeight);
    return in ? okStatus() : Status(in.error());
}

Result<ImageF> readHdrImage(const std::string& path, int maxWidth, int maxHeight) {
    auto opened = openHdrImage(path, maxWidth, maxHeight);
    if (!opened) return opened.error();
    auto& in = opened.value();
    const OIIO::ImageSpec spec = in->spec();
    const size_t n = size_t(spec.nchannels), texels = size_t(spec.width) * size_t(spec.height);
    auto read = readChannels(*in, path);
    if (!read) return read.error();
    const std::vector<float>& src = read.value();
    ImageF img;
    img.width = spec.width;
    img.height = spec.height;
    img.rgba.resize(texels * 4);
    for (size_t p = 0; p < texels; ++p) {
        const float* s = &src[p * n];
        const float rgb[3] = {s[0], n >= 3 ? s[1] : s[0], n >= 3 ? s[2] : s[0]};
        for (int c = 0; c < 3; ++c) {
            if (!std::isfinite(rgb[c])) {
                return makeError(ErrorCode::InvalidValue, "image '" + path + "': texel (" + std::to_string(p % size_t(spec.width)) +
                                                              ", " + std::to_string(p / size_t(spec.width)) + ") channel " +
                                                              std::to_string(c) + " is " + std::to_string(rgb[c]) +
                                                              ": radiance must be finite");
            }
            // Lossy EXR compression leaves tiny negatives in real maps (-1e-5 in Blender's
            // studio lights): radiance below zero is read as zero.
            img.rgba[p * 4 + size_t(c)] = std::max(rgb[c], 0.f);
        }
        img.rgba[p * 4 + 3] = 1.f;
    }
    return img;
}

} // namespace dfb
