#pragma once
// Sorting (id, payload) pairs by id, least significant digit first, over only the bits in
// which the ids differ: two or three passes for a scene's ids (they count up from 0, and
// interior ids share their top bit), where a comparison sort of the ~150k leaves of a cut
// was a fifth of a selection at a million Gaussians.
#include <algorithm>
#include <bit>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

namespace gauss::lod_detail {

using IdPair = std::pair<std::uint64_t, std::uint32_t>;

// Sorts `pairs` by id, equal ids keeping their order (the passes are stable). `scratch` (a
// vector of IdPair, any allocator) is working memory, kept by the caller so a warm caller
// does not allocate.
template <class Scratch>
void sort_by_id(std::span<IdPair> pairs, Scratch& scratch) {
  const std::size_t n = pairs.size();
  if (n < 2) return;
  IdPair* a = pairs.data();
  std::uint64_t differ = 0;
  for (std::size_t i = 1; i < n; ++i) differ |= a[i].first ^ a[0].first;
  const int bits = std::bit_width(differ);
  if (bits == 0) return;
  if (n < 256) {
    std::stable_sort(a, a + n, [](const IdPair& x, const IdPair& y) { return x.first < y.first; });
    return;
  }
  constexpr int kDigit = 8;  // 256 buckets: every bucket's write position stays in L1
  constexpr std::uint64_t kMask = (std::uint64_t{1} << kDigit) - 1;
  scratch.resize(n);
  IdPair* src = a;
  IdPair* dst = scratch.data();
  std::uint32_t counts[std::size_t{1} << kDigit];
  for (int shift = 0; shift < bits; shift += kDigit) {
    std::fill(std::begin(counts), std::end(counts), 0u);
    for (std::size_t i = 0; i < n; ++i) ++counts[(src[i].first >> shift) & kMask];
    std::uint32_t sum = 0;
    for (std::uint32_t& c : counts) sum += std::exchange(c, sum);
    for (std::size_t i = 0; i < n; ++i) dst[counts[(src[i].first >> shift) & kMask]++] = src[i];
    std::swap(src, dst);
  }
  if (src != a) std::copy(src, src + n, a);
}

}  // namespace gauss::lod_detail
