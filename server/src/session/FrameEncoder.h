#pragma once
// Turns the engine's images into the bytes a client asked for (protocol ViewSettings): the view
// transform and exposure of non-default views on the CPU, then JPEG, PNG or OpenEXR.

#include <dfb/core/Result.h>
#include <dfb/protocol/Messages.h>
#include <dfb/server/Engine.h>

#include <cstdint>
#include <vector>

namespace dfb {

/// 8-bit display image of a linear image: multiplied by 2^exposureStops, then the sRGB curve
/// ("srgb") or clamped only ("linear"). `grey`: channel 0 shown as grey (shadow masks).
Image8 toDisplay(const ImageF& linear, float exposureStops, const std::string& viewTransform, bool grey);

/// An uncompressed-size-bounded OpenEXR file in memory: float R, G, B, A, ZIP compression,
/// scaled by 2^exposureStops (scene-linear values, no view transform).
Result<std::vector<uint8_t>> encodeExr(const ImageF& linear, float exposureStops);

} // namespace dfb
