#pragma once
// Encoding frames for the wire and for files: JPEG through libjpeg-turbo (fast, for streaming),
// PNG through OpenImageIO (lossless, for scripts and tests).

#include <dfb/core/Result.h>
#include <dfb/server/Engine.h>

#include <cstdint>
#include <vector>

namespace dfb {

/// JPEG of the RGB channels, quality 1..100, 4:2:0 chroma subsampling. Thread-safe.
Result<std::vector<uint8_t>> encodeJpeg(const Image8& image, int quality = 90);

/// 8-bit RGB PNG. Thread-safe.
Result<std::vector<uint8_t>> encodePng(const Image8& image);

} // namespace dfb
