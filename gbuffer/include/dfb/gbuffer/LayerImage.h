#pragma once
// Viewable 8-bit pictures of single deep-framebuffer layers (dfb-bake --layer), for inspection.

#include <dfb/core/Result.h>
#include <dfb/gbuffer/DeepBuffer.h>

#include <cstdint>
#include <string>
#include <vector>

namespace dfb {

/// Layer names accepted by layerImage().
const std::vector<std::string>& viewableLayers();

/// Renders one layer as 8-bit RGB, row 0 at the top. Each pixel resolves its samples by coverage
/// (ids: the sample with the largest coverage). Mappings: directions 0.5 + 0.5 v; colours sRGB;
/// P normalised to the covered bounding box; Z from near (white) to far (black); ids as distinct
/// colours. Fails with InvalidValue naming the accepted layers for an unknown name.
Result<std::vector<uint8_t>> layerImage(const DeepBuffer& buffer, const std::string& layer);

} // namespace dfb
