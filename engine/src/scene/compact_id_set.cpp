#include "gauss/engine/compact_id_set.h"

#include <algorithm>

namespace gauss {

namespace {
constexpr unsigned kPageBits = 16;
constexpr std::size_t kWords = (std::size_t{1} << kPageBits) / 64;
}  // namespace

bool CompactIdSet::insert(GaussianId id) {
  const std::uint64_t v = to_underlying(id);
  Page& page = pages_[v >> kPageBits];
  const auto low = static_cast<std::uint16_t>(v);
  if (!page.bits.empty()) {
    std::uint64_t& word = page.bits[low >> 6];
    const std::uint64_t bit = std::uint64_t{1} << (low & 63);
    if (word & bit) return false;
    word |= bit;
  } else {
    const auto at = std::lower_bound(page.sorted.begin(), page.sorted.end(), low);
    if (at != page.sorted.end() && *at == low) return false;
    page.sorted.insert(at, low);
    if (page.sorted.size() >= kBitmapFrom) {
      page.bits.assign(kWords, 0);
      for (std::uint16_t l : page.sorted) page.bits[l >> 6] |= std::uint64_t{1} << (l & 63);
      std::vector<std::uint16_t>().swap(page.sorted);
    }
  }
  ++size_;
  return true;
}

bool CompactIdSet::contains(GaussianId id) const {
  const std::uint64_t v = to_underlying(id);
  const auto it = pages_.find(v >> kPageBits);
  if (it == pages_.end()) return false;
  const Page& page = it->second;
  const auto low = static_cast<std::uint16_t>(v);
  if (!page.bits.empty()) return (page.bits[low >> 6] >> (low & 63)) & 1u;
  return std::binary_search(page.sorted.begin(), page.sorted.end(), low);
}

std::size_t CompactIdSet::memory_bytes() const {
  // A hash node (key, page, next pointer, allocator header) and its bucket per page.
  std::size_t bytes = pages_.size() * (sizeof(std::uint64_t) + sizeof(Page) + 2 * sizeof(void*) + 16);
  for (const auto& [key, page] : pages_)
    bytes += page.sorted.capacity() * sizeof(std::uint16_t) + page.bits.capacity() * sizeof(std::uint64_t);
  return bytes;
}

}  // namespace gauss
