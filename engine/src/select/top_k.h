#pragma once
// Private to the selector: O(N) top-k by (score desc, position asc) over the entries whose
// partition code equals the one asked for. Positions are ranks in ascending id order (the
// selector keeps its arrays in id order), so "lower position" is "lower id": the spec's
// tie rule without reading 64-bit ids. One histogram pass over the top 16 bits of the
// score key finds the threshold bucket; a second pass marks everything above it and
// gathers the bucket's members as one 64-bit word each, of which nth_element picks the
// rest. No sort of N, no allocation once warm.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <span>
#include <vector>

namespace gauss::select_detail {

// Non-negative finite floats order like their bit patterns; anything else ranks last.
inline std::uint32_t score_key(float score) {
  if (!(score > 0.0f) || !std::isfinite(score)) return 0;
  return std::bit_cast<std::uint32_t>(score);
}

class TopK {
 public:
  // Marks the k best entries with code[j] == want in `selected` (1) and returns how many
  // were marked: min(k, number of such entries). Positions need 32 bits.
  std::size_t select(std::span<const std::uint32_t> keys, std::span<const std::uint8_t> code, std::uint8_t want,
                     std::size_t k, std::span<std::uint8_t> selected) {
    if (k == 0) return 0;
    const std::size_t n = keys.size();
    // One extra bucket collects the entries of other partitions, so the counting loop
    // has no branch on the code.
    hist_.assign(kBuckets + 1, 0);
    const std::uint32_t* key = keys.data();
    const std::uint8_t* c = code.data();
    std::uint32_t* h = hist_.data();
    for (std::size_t j = 0; j < n; ++j) ++h[c[j] == want ? key[j] >> 16 : kBuckets];
    const std::size_t candidates = n - hist_[kBuckets];
    if (candidates <= k) {
      for (std::size_t j = 0; j < n; ++j) selected[j] |= static_cast<std::uint8_t>(c[j] == want);
      return candidates;
    }
    // Walk buckets from the best down until k are covered.
    std::size_t above = 0;
    std::uint32_t b = kBuckets - 1;
    while (above + hist_[b] < k) above += hist_[b--];
    const std::size_t need = k - above;
    bucket_.clear();
    bucket_.reserve(hist_[b]);
    std::uint8_t* sel = selected.data();
    for (std::size_t j = 0; j < n; ++j) {
      if (c[j] != want) continue;
      const std::uint32_t hb = key[j] >> 16;
      sel[j] |= static_cast<std::uint8_t>(hb > b);
      // Higher key first, then lower position: (key, ~position) as one word, larger wins.
      if (hb == b) bucket_.push_back((std::uint64_t{key[j]} << 32) | (0xFFFFFFFFu - static_cast<std::uint32_t>(j)));
    }
    if (need < bucket_.size()) {
      std::nth_element(bucket_.begin(), bucket_.begin() + static_cast<std::ptrdiff_t>(need), bucket_.end(),
                       std::greater<>());
    }
    for (std::size_t t = 0; t < need; ++t) sel[0xFFFFFFFFu - static_cast<std::uint32_t>(bucket_[t])] = 1;
    return k;
  }

 private:
  static constexpr std::uint32_t kBuckets = 1u << 16;
  std::vector<std::uint32_t> hist_;
  std::vector<std::uint64_t> bucket_;
};

}  // namespace gauss::select_detail
