#pragma once
// SlotTable: the client's map from persistent Gaussian id to a stable GPU slot, with
// a CPU mirror of every slot's record. Capacity (the budget M) is fixed at creation.
// A Gaussian keeps its slot while resident; written slots are marked dirty, and
// take_dirty_ranges() merges adjacent dirty slots into the ranges the renderer's
// stable-slot buffer uploads (write_slots(first_slot, span<const Gaussian>)).
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/id_index.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/result.h"

namespace gauss {

// Largest budget a client may ask for: 2 Mi slots. M up to 400k is the design point;
// anything far beyond (e.g. a hello claiming 10^9) is a bad or hostile value, and
// accepting it would make the host plan for a set no headset can hold.
inline constexpr std::uint32_t kMaxSlotCapacity = 1u << 21;

// A run of consecutive dirty slots: upload records[first .. first + count).
struct SlotRange {
  std::uint32_t first{0};
  std::uint32_t count{0};
  bool operator==(const SlotRange&) const = default;
};

class SlotTable {
 public:
  // Fails (naming the value) for capacity 0 or above kMaxSlotCapacity.
  static Expected<SlotTable> create(std::uint32_t capacity);

  std::uint32_t capacity() const noexcept { return static_cast<std::uint32_t>(slot_ids_.size()); }
  std::uint32_t size() const noexcept { return capacity() - static_cast<std::uint32_t>(free_.size()); }
  std::uint32_t free_count() const noexcept { return static_cast<std::uint32_t>(free_.size()); }

  // Gives `id` a free slot and stores `value` there. Fails when the table is full or the
  // id already holds a slot (both leave the table untouched).
  Expected<SlotIndex> insert(GaussianId id, const Gaussian& value);
  // Overwrites the record of a resident id in place. Fails for a non-resident id.
  Status update(GaussianId id, const Gaussian& value);
  // Frees the id's slot (the slot is cleared to an empty record and marked dirty so the
  // renderer skips it). Fails for a non-resident id.
  Status remove(GaussianId id);
  // `leaving` leaves and `entering` takes over its slot with `value`: one slot write.
  Expected<SlotIndex> replace(GaussianId leaving, GaussianId entering, const Gaussian& value);

  SlotIndex slot_of(GaussianId id) const;            // kNoSlot when not resident
  bool contains(GaussianId id) const { return index_.find(to_underlying(id)) != nullptr; }
  // Writes the id resident in `slot` to out_id; false when the slot is free or out of range.
  bool occupant(SlotIndex slot, GaussianId& out_id) const;
  // The resident ids in slot order (free slots skipped): the order a renderer blends equal
  // depths in, which a second render of the same set must reproduce (gauss-render --order).
  std::vector<GaussianId> occupants() const;
  std::span<const Gaussian> records() const noexcept { return records_; }

  // Dirty slots since the last call, sorted and merged: adjacent slots form one range;
  // with max_gap > 0, ranges separated by at most max_gap clean slots are merged too
  // (re-uploading a few clean slots is cheaper than another copy command).
  std::vector<SlotRange> take_dirty_ranges(std::uint32_t max_gap = 0);
  std::uint32_t dirty_count() const noexcept { return static_cast<std::uint32_t>(dirty_list_.size()); }
  // Written since the last take_dirty_ranges() (false out of range).
  bool is_dirty(std::uint32_t slot) const noexcept { return slot < dirty_.size() && dirty_[slot] != 0; }

  // Full consistency check (id <-> slot bijection, free list disjoint from used slots,
  // no slot twice). O(capacity); for tests and the simulation's per-frame invariants.
  Status check() const;

 private:
  explicit SlotTable(std::uint32_t capacity);
  void mark_dirty(std::uint32_t slot);

  static constexpr std::uint64_t kEmpty = detail::IdIndex::kEmpty;
  // id -> slot: a flat table (an unordered_map cost a node allocation and a second cache
  // miss per publication), reserved for the capacity at creation.
  detail::IdIndex index_;
  std::vector<std::uint64_t> slot_ids_;                    // slot -> id, kEmpty when free
  // CPU mirror of the GPU buffer, on huge pages like DesiredState's entries: publication
  // writes records at random slots of a table of tens of megabytes.
  std::vector<Gaussian, detail::TableAllocator<Gaussian>> records_;
  std::vector<std::uint32_t> free_;                        // LIFO; lowest slots handed out first
  std::vector<std::uint8_t> dirty_;
  std::vector<std::uint32_t> dirty_list_;
};

// FNV-1a style order-independent checksum of (id, record) pairs: equal sets of equal
// records give equal sums whatever the order or slots. Used to compare published
// against desired state exactly.
std::uint64_t record_hash(GaussianId id, const Gaussian& g);

}  // namespace gauss
