// The median of a sample of timings, as the benchmarks report them: the
// middle value, or the mean of the two middle values of an even sample.
// Trade-off: sorts a copy (samples are a handful of timings).
#pragma once
#include <algorithm>
#include <cstddef>
#include <vector>

namespace parode {

// 0 for an empty sample.
inline double median(std::vector<double> v) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace parode
