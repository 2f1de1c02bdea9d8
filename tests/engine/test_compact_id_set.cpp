// CompactIdSet: the same answers as a std::set on dense, scattered and mixed ids across the
// switch from a page's sorted array to its bitmap, and the memory it was made for: removed
// ids that a store allocated in sequence cost at most 2 bytes each, a bit each once dense.
#include <cstdint>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "gauss/engine/compact_id_set.h"

namespace gauss {
namespace {

GaussianId id(std::uint64_t v) { return GaussianId{v}; }

TEST(CompactIdSet, AnswersAsASetDoesAcrossPagesAndTheBitmapSwitch) {
  CompactIdSet s;
  std::set<std::uint64_t> truth;
  std::mt19937_64 rng(7);
  const auto add = [&](std::uint64_t v) {
    EXPECT_EQ(s.insert(id(v)), truth.insert(v).second) << v;
  };
  // A page filled past kBitmapFrom in random order, one left just below it, scattered ids
  // (one page each), the ends of the range, and every id added twice.
  for (int i = 0; i < 9000; ++i) add((std::uint64_t{3} << 16) | (rng() & 0xFFFF));
  for (std::uint64_t v = 0; v + 1 < CompactIdSet::kBitmapFrom; ++v) add((std::uint64_t{5} << 16) + 2 * v);
  for (int i = 0; i < 2000; ++i) add(rng());
  add(0);
  add(~std::uint64_t{0});
  add((std::uint64_t{7} << 16) | 0xFFFF);
  for (std::uint64_t v : std::set<std::uint64_t>(truth)) add(v);
  EXPECT_EQ(s.size(), truth.size());
  for (std::uint64_t v : truth) EXPECT_TRUE(s.contains(id(v))) << v;
  // Neighbours of members, other pages, and random values.
  std::size_t checked = 0;
  for (std::uint64_t v : truth) {
    for (std::uint64_t w : {v - 1, v + 1})
      if (!truth.count(w)) {
        EXPECT_FALSE(s.contains(id(w))) << w;
        ++checked;
      }
  }
  for (int i = 0; i < 20000; ++i) {
    const std::uint64_t v = (std::uint64_t{3} << 16) | (rng() & 0xFFFF);
    EXPECT_EQ(s.contains(id(v)), truth.count(v) == 1) << v;
  }
  EXPECT_FALSE(s.contains(id(std::uint64_t{4} << 16)));
  EXPECT_GT(checked, 1000u);
}

TEST(CompactIdSet, RemovedSequentialIdsCostAtMostTwoBytesEach) {
  // A million ids allocated in sequence, of which a random 30 % were removed (the store's
  // pattern: a trainer's snapshot drops Gaussians anywhere), then all of them.
  CompactIdSet some, all;
  std::mt19937_64 rng(11);
  std::size_t n = 0;
  for (std::uint64_t v = 1; v <= 1000000; ++v) {
    if (rng() % 10 < 3) {
      some.insert(id(v));
      ++n;
    }
    all.insert(id(v));
  }
  EXPECT_EQ(some.size(), n);
  // 30 % of each page is about 19.7k ids: bitmaps, 8 KiB a page of 65536 ids.
  EXPECT_LE(some.memory_bytes(), n * 2) << some.memory_bytes();
  // All of them: a bit for every id of the 16 pages they reach (8 KiB each), and a page's node.
  EXPECT_LE(all.memory_bytes(), 16 * (8192 + 128)) << all.memory_bytes();
  // Sparse pages stay arrays: 1000 ids in one page take their 2 bytes, not a bitmap.
  CompactIdSet sparse;
  for (std::uint64_t v = 0; v < 1000; ++v) sparse.insert(id(v * 50));
  EXPECT_LE(sparse.memory_bytes(), 1000 * 2 + 256) << sparse.memory_bytes();
}

}  // namespace
}  // namespace gauss
