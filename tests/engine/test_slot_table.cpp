// SlotTable: fixed capacity, free list, id <-> slot bijection, dirty range merging.
#include <gtest/gtest.h>

#include <random>
#include <set>

#include "gauss/engine/slot_table.h"

using namespace gauss;

namespace {
Gaussian g_at(float x) {
  Gaussian g;
  g.position = {x, 0.0f, 0.0f};
  return g;
}
}  // namespace

TEST(SlotTable, RejectsZeroAndAbsurdCapacity) {
  auto zero = SlotTable::create(0);
  ASSERT_FALSE(zero.ok());
  EXPECT_NE(zero.message().find("capacity 0"), std::string::npos);
  auto huge = SlotTable::create(1000000000u);
  ASSERT_FALSE(huge.ok());
  EXPECT_NE(huge.message().find("1000000000"), std::string::npos);
  EXPECT_TRUE(SlotTable::create(400000).ok());
  EXPECT_FALSE(SlotTable::create(kMaxSlotCapacity + 1).ok());
}

TEST(SlotTable, InsertRemoveReusesSlotsLowestFirst) {
  auto t = SlotTable::create(4).value();
  EXPECT_EQ(to_underlying(t.insert(GaussianId{10}, g_at(1)).value()), 0u);
  EXPECT_EQ(to_underlying(t.insert(GaussianId{11}, g_at(2)).value()), 1u);
  EXPECT_EQ(to_underlying(t.insert(GaussianId{12}, g_at(3)).value()), 2u);
  ASSERT_TRUE(t.remove(GaussianId{11}).ok());
  EXPECT_EQ(t.slot_of(GaussianId{11}), kNoSlot);
  EXPECT_EQ(to_underlying(t.insert(GaussianId{13}, g_at(4)).value()), 1u);  // freed slot reused
  EXPECT_EQ(t.size(), 3u);
  EXPECT_EQ(t.records()[1].position.x, 4.0f);
  GaussianId who{0};
  ASSERT_TRUE(t.occupant(SlotIndex{1}, who));
  EXPECT_EQ(who, GaussianId{13});
  EXPECT_FALSE(t.occupant(SlotIndex{3}, who));
  EXPECT_FALSE(t.occupant(SlotIndex{99}, who));
  ASSERT_TRUE(t.remove(GaussianId{10}).ok());
  // Slot order, the free slots 0 and 3 skipped.
  EXPECT_EQ(t.occupants(), (std::vector<GaussianId>{GaussianId{13}, GaussianId{12}}));
  EXPECT_TRUE(t.check().ok());
}

TEST(SlotTable, FullDuplicateAndUnknownAreRejectedUntouched) {
  auto t = SlotTable::create(2).value();
  ASSERT_TRUE(t.insert(GaussianId{1}, g_at(1)).ok());
  auto dup = t.insert(GaussianId{1}, g_at(9));
  ASSERT_FALSE(dup.ok());
  EXPECT_NE(dup.message().find("already holds"), std::string::npos);
  EXPECT_EQ(t.records()[0].position.x, 1.0f);
  ASSERT_TRUE(t.insert(GaussianId{2}, g_at(2)).ok());
  auto full = t.insert(GaussianId{3}, g_at(3));
  ASSERT_FALSE(full.ok());
  EXPECT_NE(full.message().find("full"), std::string::npos);
  EXPECT_FALSE(t.update(GaussianId{7}, g_at(0)).ok());
  EXPECT_FALSE(t.remove(GaussianId{7}).ok());
  EXPECT_FALSE(t.replace(GaussianId{7}, GaussianId{8}, g_at(0)).ok());
  EXPECT_FALSE(t.replace(GaussianId{1}, GaussianId{2}, g_at(0)).ok());  // entering already resident
  EXPECT_EQ(t.size(), 2u);
  EXPECT_TRUE(t.check().ok());
}

TEST(SlotTable, ReplaceKeepsTheSlot) {
  auto t = SlotTable::create(3).value();
  ASSERT_TRUE(t.insert(GaussianId{1}, g_at(1)).ok());
  ASSERT_TRUE(t.insert(GaussianId{2}, g_at(2)).ok());
  (void)t.take_dirty_ranges();
  auto s = t.replace(GaussianId{2}, GaussianId{5}, g_at(5));
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(to_underlying(*s), 1u);
  EXPECT_FALSE(t.contains(GaussianId{2}));
  EXPECT_EQ(t.slot_of(GaussianId{5}), SlotIndex{1});
  EXPECT_EQ(t.take_dirty_ranges(), (std::vector<SlotRange>{{1, 1}}));
  EXPECT_TRUE(t.check().ok());
}

TEST(SlotTable, DirtySlotsMergeIntoRanges) {
  auto t = SlotTable::create(16).value();
  for (std::uint64_t i = 0; i < 16; ++i) ASSERT_TRUE(t.insert(GaussianId{100 + i}, g_at(0)).ok());
  EXPECT_EQ(t.take_dirty_ranges(), (std::vector<SlotRange>{{0, 16}}));
  EXPECT_TRUE(t.take_dirty_ranges().empty());
  // Touch slots 9, 3, 4, 5, 12, 4 (twice) in scattered order.
  for (std::uint64_t s : {9u, 3u, 4u, 5u, 12u, 4u}) ASSERT_TRUE(t.update(GaussianId{100 + s}, g_at(1)).ok());
  EXPECT_EQ(t.dirty_count(), 5u);
  EXPECT_EQ(t.take_dirty_ranges(), (std::vector<SlotRange>{{3, 3}, {9, 1}, {12, 1}}));
  for (std::uint64_t s : {3u, 5u, 9u, 12u}) ASSERT_TRUE(t.update(GaussianId{100 + s}, g_at(2)).ok());
  // With a gap allowance of 3 clean slots, 3..5 and 9 merge (gap 6,7,8), 12 too (gap 10,11).
  EXPECT_EQ(t.take_dirty_ranges(3), (std::vector<SlotRange>{{3, 10}}));
}

TEST(SlotTable, RandomOperationsKeepTheBijection) {
  std::mt19937_64 rng(7);
  auto t = SlotTable::create(64).value();
  std::set<std::uint64_t> resident;
  std::uint64_t next_id = 1;
  for (int step = 0; step < 5000; ++step) {
    const int op = static_cast<int>(rng() % 3);
    if (op == 0 && resident.size() < 64) {
      ASSERT_TRUE(t.insert(GaussianId{next_id}, g_at(0)).ok());
      resident.insert(next_id++);
    } else if (op == 1 && !resident.empty()) {
      auto it = resident.begin();
      std::advance(it, static_cast<long>(rng() % resident.size()));
      ASSERT_TRUE(t.remove(GaussianId{*it}).ok());
      resident.erase(it);
    } else if (!resident.empty()) {
      auto it = resident.begin();
      std::advance(it, static_cast<long>(rng() % resident.size()));
      ASSERT_TRUE(t.replace(GaussianId{*it}, GaussianId{next_id}, g_at(1)).ok());
      resident.erase(it);
      resident.insert(next_id++);
    }
    if (step % 97 == 0) {
      ASSERT_TRUE(t.check().ok()) << t.check().message();
      // Ranges cover exactly the dirty slots, sorted, disjoint, non-adjacent.
      auto ranges = t.take_dirty_ranges();
      for (std::size_t i = 1; i < ranges.size(); ++i) ASSERT_GT(ranges[i].first, ranges[i - 1].first + ranges[i - 1].count);
    }
  }
  EXPECT_EQ(t.size(), resident.size());
  for (auto id : resident) EXPECT_NE(t.slot_of(GaussianId{id}), kNoSlot);
}

TEST(SlotTable, RecordHashSeparatesRecords) {
  Gaussian a = g_at(1), b = g_at(1);
  EXPECT_EQ(record_hash(GaussianId{1}, a), record_hash(GaussianId{1}, b));
  EXPECT_NE(record_hash(GaussianId{1}, a), record_hash(GaussianId{2}, a));
  b.sh_rest[14].z = 1e-7f;
  EXPECT_NE(record_hash(GaussianId{1}, a), record_hash(GaussianId{1}, b));
}
