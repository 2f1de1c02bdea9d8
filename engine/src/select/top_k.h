#pragma once
// Private to the selector: O(N) top-k by (score desc, id asc) over the candidates a
// predicate accepts. One histogram pass over the top 16 bits of the score key finds the
// threshold bucket; a second pass takes everything above it and gathers the bucket's
// members, of which nth_element picks the rest. No sort of N, no allocation once warm.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
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
  // Marks the k best candidates (pred(i) true) in `selected` (1) and returns how many
  // were marked: min(k, number of candidates).
  template <class Pred>
  std::size_t select(std::span<const std::uint32_t> keys, std::span<const std::uint64_t> ids, Pred&& pred,
                     std::size_t k, std::vector<std::uint8_t>& selected) {
    if (k == 0) return 0;
    const std::size_t n = keys.size();
    hist_.assign(kBuckets, 0);
    std::size_t candidates = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!pred(i)) continue;
      ++hist_[keys[i] >> 16];
      ++candidates;
    }
    if (candidates <= k) {
      for (std::size_t i = 0; i < n; ++i)
        if (pred(i)) selected[i] = 1;
      return candidates;
    }
    // Walk buckets from the best down until k are covered.
    std::size_t above = 0;
    std::uint32_t b = kBuckets - 1;
    while (above + hist_[b] < k) above += hist_[b--];
    const std::size_t need = k - above;
    bucket_.clear();
    std::size_t marked = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!pred(i)) continue;
      const std::uint32_t hb = keys[i] >> 16;
      if (hb > b) {
        selected[i] = 1;
        ++marked;
      } else if (hb == b) {
        bucket_.push_back(Entry{keys[i], ids[i], static_cast<std::uint32_t>(i)});
      }
    }
    auto better = [](const Entry& a, const Entry& c) { return a.key != c.key ? a.key > c.key : a.id < c.id; };
    if (need < bucket_.size()) {
      std::nth_element(bucket_.begin(), bucket_.begin() + static_cast<std::ptrdiff_t>(need), bucket_.end(), better);
    }
    for (std::size_t j = 0; j < need; ++j) selected[bucket_[j].index] = 1;
    return marked + need;
  }

 private:
  static constexpr std::uint32_t kBuckets = 1u << 16;
  struct Entry {
    std::uint32_t key;
    std::uint64_t id;
    std::uint32_t index;
  };
  std::vector<std::uint32_t> hist_;
  std::vector<Entry> bucket_;
};

}  // namespace gauss::select_detail
