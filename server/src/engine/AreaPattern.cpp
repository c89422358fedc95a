#include <dfb/server/AreaPattern.h>

#include <dfb/server/ImageCodec.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <mutex>
#include <tuple>

namespace dfb {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

std::mutex gMutex;
std::map<std::pair<std::string, bool>, std::shared_ptr<const AreaPatternTable>> gTables; // by (file, disk)
std::map<std::tuple<std::string, bool, int>, std::array<float, 2>> gFits; // by (file, disk, aspect step)

std::string patternPath(const Light& l, const std::string& assetDir) {
    return l.pattern.empty() ? std::string() : (std::filesystem::path(assetDir) / l.pattern).string();
}

// The image box-filtered down to at most AREA_PATTERN_MAX_SIDE per side (whole source texels per
// table texel, the remainder spread over the last ones), RGB.
std::vector<float> filteredRgb(const ImageF& img, int& w, int& h) {
    const int fx = (img.width + AREA_PATTERN_MAX_SIDE - 1) / AREA_PATTERN_MAX_SIDE;
    const int fy = (img.height + AREA_PATTERN_MAX_SIDE - 1) / AREA_PATTERN_MAX_SIDE;
    w = (img.width + fx - 1) / fx;
    h = (img.height + fy - 1) / fy;
    std::vector<double> sum(size_t(w) * size_t(h) * 3, 0.0);
    std::vector<int> count(size_t(w) * size_t(h), 0);
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const size_t o = size_t(y / fy) * size_t(w) + size_t(x / fx), i = (size_t(y) * size_t(img.width) + size_t(x)) * 4;
            for (int c = 0; c < 3; ++c) {
                const float v = img.rgba[i + size_t(c)];
                sum[o * 3 + size_t(c)] += std::isfinite(v) ? std::max(v, 0.f) : 0.f; // a pattern multiplies: >= 0
            }
            ++count[o];
        }
    std::vector<float> out(sum.size());
    for (size_t k = 0; k < out.size(); ++k) out[k] = float(sum[k] / std::max(count[k / 3], 1));
    return out;
}

} // namespace

Result<std::shared_ptr<const AreaPatternTable>> areaPatternTable(const Light& l, const std::string& assetDir) {
    const std::string path = patternPath(l, assetDir);
    const bool disk = l.areaShape == AreaShape::Disk;
    {
        std::lock_guard lock(gMutex);
        auto it = gTables.find({path, disk});
        if (it != gTables.end()) return it->second;
    }
    const auto t0 = Clock::now();
    auto out = std::make_shared<AreaPatternTable>();
    if (path.empty()) {
        out->table = lightmath::buildPatternTable(nullptr, 0, 0, disk);
    } else {
        auto img = readLinearImage(path);
        if (!img) return makeError(img.error().code, "light '" + l.name + "': pattern '" + l.pattern + "': " + img.error().message);
        int w = 0, h = 0;
        const std::vector<float> rgb = filteredRgb(img.value(), w, h);
        out->table = lightmath::buildPatternTable(rgb.data(), w, h, disk);
        if (!(out->table.mean.x + out->table.mean.y + out->table.mean.z > 0.0)) {
            return makeError(ErrorCode::InvalidValue, "light '" + l.name + "': pattern '" + l.pattern + "' is black: the light would emit nothing");
        }
    }
    out->buildMs = msSince(t0);
    std::lock_guard lock(gMutex);
    return gTables.emplace(std::make_pair(path, disk), out).first->second;
}

Result<std::array<float, 2>> fitAreaAlphaBeta(const Light& l, const std::string& assetDir, double* fitMs) {
    if (fitMs) *fitMs = 0.0;
    const bool disk = l.areaShape == AreaShape::Disk;
    const double aspect = disk ? 1.0 : double(l.areaSize[0]) / double(l.areaSize[1]);
    const int step = int(std::lround(16.0 * std::log2(std::clamp(aspect, 1e-6, 1e6))));
    const auto key = std::make_tuple(patternPath(l, assetDir), disk, step);
    {
        std::lock_guard lock(gMutex);
        auto it = gFits.find(key);
        if (it != gFits.end()) return it->second;
    }
    auto table = areaPatternTable(l, assetDir);
    if (!table) return table.error();
    const auto t0 = Clock::now();
    // The fit is scale-free: a unit emitter of the bucket's aspect, facing +z.
    const double a = std::exp2(step / 16.0);
    const lightmath::AreaFrame<double> f =
        lightmath::areaFrame<double>({0, 0, 0}, {0, 0, 1}, 0.0, {disk ? 1.0 : std::sqrt(a), disk ? 1.0 : 1.0 / std::sqrt(a)}, disk);
    std::array<float, 2> ab{0.30f, 0.57f};
    int n = 0;
    const double alpha = lightmath::fitRadiusFactor(f, table.value()->table, 1.0, 32, &n);
    if (n > 0) ab[0] = float(alpha);
    double beta = 0.0;
    int betas = 0;
    for (double m : lightmath::BETA_FIT_EXPONENTS) {
        const double b = lightmath::fitRadiusFactor(f, table.value()->table, m, 32, &n);
        if (n > 0) beta += b, ++betas;
    }
    if (betas > 0) ab[1] = float(beta / betas);
    if (fitMs) *fitMs = msSince(t0);
    std::lock_guard lock(gMutex);
    return gFits.emplace(key, ab).first->second;
}

} // namespace dfb
