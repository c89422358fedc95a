#include <dfb/server/ImageCodec.h>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <turbojpeg.h>

namespace dfb {

Result<std::vector<uint8_t>> encodeJpeg(const Image8& image, int quality) {
    if (image.width <= 0 || image.height <= 0) return makeError(ErrorCode::InvalidValue, "encodeJpeg: empty image");
    tjhandle tj = tjInitCompress();
    if (!tj) return makeError(ErrorCode::IoError, std::string("tjInitCompress: ") + tjGetErrorStr());
    unsigned char* out = nullptr;
    unsigned long size = 0;
    const int rc = tjCompress2(tj, image.rgba.data(), image.width, image.width * 4, image.height, TJPF_RGBA, &out,
                               &size, TJSAMP_420, std::clamp(quality, 1, 100), TJFLAG_FASTDCT);
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

} // namespace dfb
