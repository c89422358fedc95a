#pragma once
// Summary statistics for benchmarks and the clients' latency reports: one convention everywhere.

#include <algorithm>
#include <cmath>
#include <vector>

namespace dfb {

/// The `percent` percentile (0..100) of `values` by linear interpolation between the closest
/// ranks (NumPy's default, "linear"): 0 is the minimum, 100 the maximum, 50 the median. NaN when
/// there are no values.
inline double percentile(std::vector<double> values, double percent) {
    if (values.empty()) return NAN;
    std::sort(values.begin(), values.end());
    const double idx = std::clamp(percent, 0.0, 100.0) / 100.0 * double(values.size() - 1);
    const size_t lo = size_t(std::floor(idx)), hi = size_t(std::ceil(idx));
    return values[lo] + (values[hi] - values[lo]) * (idx - double(lo));
}

} // namespace dfb
