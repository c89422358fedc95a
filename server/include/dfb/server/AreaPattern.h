#pragma once
// An area light's emitter and pattern on the CPU (docs/lighting.md, "Area lights"): its frame
// from the rig light, the pattern's summed-area table read from the asset folder, and the
// one-shot radius factors alpha and beta fitted for its shape and pattern (Wang et al. 2008,
// section 3). The tables and fits are cached process-wide (thread-safe): the session fits on an
// edit (Light::alphaBeta), the engine uploads the same table.

#include <dfb/core/Result.h>
#include <dfb/lightmath/AreaLight.h>
#include <dfb/protocol/Rig.h>

#include <array>
#include <memory>
#include <string>

namespace dfb {

/// Largest side of a pattern's table: larger images are box-filtered down to it (one-shot blurs
/// by at least alpha |p t| anyway; 256 x 256 RGBA32F corners are 1 MiB on the GPU).
constexpr int AREA_PATTERN_MAX_SIDE = 256;

/// The emitter of an area light (lightmath::areaFrame of its position, direction, roll, size, shape).
template <typename T> lightmath::AreaFrame<T> areaFrameOf(const Light& l) {
    return lightmath::areaFrame<T>({l.position[0], l.position[1], l.position[2]}, {l.direction[0], l.direction[1], l.direction[2]},
                                   T(l.rollDeg), {l.areaSize[0], l.areaSize[1]}, l.areaShape == AreaShape::Disk);
}

/// A pattern's table and what building it cost.
struct AreaPatternTable {
    lightmath::PatternTable table;
    double buildMs = 0.0; ///< reading the image, filtering it down and summing
};

/// The table of l.pattern (relative to `assetDir`; uniform when empty) for l's shape, cached by
/// file and shape. Errors name the light and the pattern.
Result<std::shared_ptr<const AreaPatternTable>> areaPatternTable(const Light& l, const std::string& assetDir);

/// The fitted (alpha, beta) for l's shape, aspect and pattern (lightmath::fitRadiusFactor: alpha at
/// m = 1, beta the mean over BETA_FIT_EXPONENTS), cached by file, shape and aspect (in steps of
/// 1/16 of an octave, so that a resize drag refits only when the aspect changes by 4 %).
/// `fitMs`: the time the fit took (0 when cached).
Result<std::array<float, 2>> fitAreaAlphaBeta(const Light& l, const std::string& assetDir, double* fitMs = nullptr);

} // namespace dfb
