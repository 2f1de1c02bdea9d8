#pragma once
// Percentiles of a sample (frame times), linearly interpolated between order statistics:
// p = 0.5 of an even count is the mean of the middle two. 0 for an empty sample.
#include <algorithm>
#include <cstddef>
#include <vector>

namespace gauss::apps {

inline double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double idx = std::clamp(p, 0.0, 1.0) * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(idx);
  const auto hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (v[hi] - v[lo]) * (idx - static_cast<double>(lo));
}

}  // namespace gauss::apps
