#pragma once
// CompactIdSet: a set of Gaussian ids that stays small where the ids are dense. The scene
// store keeps every id a session ever removed (ids are never reused), and that set only grows:
// a host following a trainer's snapshots drops a share of its Gaussians at every snapshot, and
// as a std::unordered_set each removed id took about 64 bytes (30 epochs removing 300k of 1M:
// 600 MB, more than the scene itself).
//
// Ids are grouped in pages of 2^16 by their high bits. A page keeps its ids' low 16 bits as a
// sorted array (2 bytes each) up to kBitmapFrom of them, then as a bitmap of 8 KiB (1 bit per
// id the page can hold), so ids that a store allocated in sequence cost at most 2 bytes each.
// Scattered ids (one per page) cost about a hash node each, as before.
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "gauss/engine/ids.h"

namespace gauss {

class CompactIdSet {
 public:
  // A page switches from its sorted array to a bitmap at this many ids (the array's bytes
  // then equal the bitmap's).
  static constexpr std::size_t kBitmapFrom = 4096;

  // Adds `id`; false when it was there already.
  bool insert(GaussianId id);
  bool contains(GaussianId id) const;
  std::size_t size() const { return size_; }
  // The bytes its pages hold (arrays, bitmaps and an estimate of the page table's nodes).
  std::size_t memory_bytes() const;

 private:
  struct Page {
    std::vector<std::uint16_t> sorted;  // the low bits, ascending, while a small page
    std::vector<std::uint64_t> bits;    // 1024 words once the page became a bitmap
  };
  std::unordered_map<std::uint64_t, Page> pages_;
  std::size_t size_{0};
};

}  // namespace gauss
