#pragma once
// Private to the scene folder: a uniform grid over 3D points or boxes, stored as a vector
// of (cell key, item) pairs sorted by key plus each occupied cell's range in it. Used by
// the eligibility filter (triangles); the identity tracker shares its cell coordinates and
// keys (previous Gaussians, with the ranges in an IdIndex).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

namespace gauss::scene {

// Integer cell coordinate of v; far outliers share the border cells.
inline std::int64_t cell_coord(float v, float cell) {
  return static_cast<std::int64_t>(std::clamp(std::floor(double(v) / double(cell)), -1.0e6, 1.0e6));
}

// 21 bits per axis (coordinates are within +-1e6 < 2^20, so keys are unique).
inline std::uint64_t cell_key(std::int64_t x, std::int64_t y, std::int64_t z) {
  const auto wrap = [](std::int64_t v) { return static_cast<std::uint64_t>(v) & 0x1FFFFFull; };
  return (wrap(x) << 42) | (wrap(y) << 21) | wrap(z);
}

using CellRanges = std::unordered_map<std::uint64_t, std::pair<std::uint32_t, std::uint32_t>>;

// Each key's [begin, end) in `by_cell`, which must be sorted by key.
inline CellRanges cell_ranges(const std::vector<std::pair<std::uint64_t, std::uint32_t>>& by_cell) {
  CellRanges ranges;
  ranges.reserve(by_cell.size());
  for (std::size_t a = 0; a < by_cell.size();) {
    std::size_t b = a;
    while (b < by_cell.size() && by_cell[b].first == by_cell[a].first) ++b;
    ranges.emplace(by_cell[a].first, std::make_pair(static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b)));
    a = b;
  }
  return ranges;
}

}  // namespace gauss::scene
