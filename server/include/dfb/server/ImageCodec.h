#pragma once
// Encoding frames for the wire and for files: JPEG through libjpeg-turbo (fast, for streaming),
// PNG through OpenImageIO (lossless, for scripts and tests).

#include <dfb/core/Result.h>
#include <dfb/server/Engine.h>

#include <cstdint>
#include <string>
#include <vector>

namespace dfb {

/// JPEG of the RGB channels, quality 1..100, 4:2:0 chroma subsampling. Thread-safe. Tall images
/// are encoded in strips on several threads, joined with restart markers (same decoded pixels).
/// `threads`: at most this many strips (0: one per hardware thread, up to 16).
Result<std::vector<uint8_t>> encodeJpeg(const Image8& image, int quality = 90, int threads = 0);

/// A small JPEG of a JPEG (snapshot thumbnails): decoded by libjpeg-turbo at the largest of its
/// DCT scaling factors (1/8 .. 1) that gives at most `maxWidth` columns, re-encoded at `quality`.
/// InvalidValue names what is wrong with bytes that are not a JPEG. Thread-safe.
Result<std::vector<uint8_t>> jpegThumbnail(const uint8_t* jpeg, size_t size, int maxWidth, int quality = 80);

/// 8-bit RGB PNG. Thread-safe.
Result<std::vector<uint8_t>> encodePng(const Image8& image);

/// A scanline OpenEXR file in memory, 32-bit float channels, ZIP compression, row 0 at the top.
/// Each layer: `name` empty = the main R, G, B, A channels; otherwise the channels NAME.R, NAME.G,
/// NAME.B (the EXR layer convention compositors read as light groups). All layers must have the
/// same size. Thread-safe.
Result<std::vector<uint8_t>> encodeExr(const std::vector<NamedImageF>& layers);

/// Checks that `path` is an image OpenImageIO can open, of a size the engine takes (header only:
/// cheap enough for the network thread). Errors name the file.
Status checkImageFile(const std::string& path);

/// Reads any image OpenImageIO reads as linear float RGBA (integer-coded files are taken as sRGB
/// and decoded; float files as linear; grey is replicated, missing alpha is 1). Errors name the file.
Result<ImageF> readLinearImage(const std::string& path);

/// Checks that `path` is an HDR image an environment light takes (header only): float data
/// (OpenEXR, Radiance HDR, float TIFF: 8- and 16-bit integer images are refused, their values are
/// not radiance), at most maxWidth x maxHeight texels. Errors name the file and what is wrong.
Status checkHdrImageFile(const std::string& path, int maxWidth, int maxHeight);

/// Reads such an image as linear RGBA float (grey replicated); refuses a non-finite texel, naming
/// it; negative values (lossy compression's) are read as 0.
Result<ImageF> readHdrImage(const std::string& path, int maxWidth, int maxHeight);

} // namespace dfb
