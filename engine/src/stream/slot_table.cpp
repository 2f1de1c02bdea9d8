#include "gauss/engine/slot_table.h"

#include <algorithm>
#include <bit>

#include "gauss/engine/log_text.h"
#include "stream/splitmix.h"

namespace gauss {

// A well-mixed 64-bit value per field (splitmix64), so the sum over a set (order
// independent) still separates sets that differ in one bit of one record.
std::uint64_t record_hash(GaussianId id, const Gaussian& g) {
  std::uint64_t h = splitmix64(to_underlying(id));
  auto add = [&h](std::uint64_t v) { h = splitmix64(h ^ v); };
  auto add_f = [&add](float f) { add(std::bit_cast<std::uint32_t>(f)); };
  for (int i = 0; i < 3; ++i) add_f(g.position[i]);
  for (int i = 0; i < 3; ++i) add_f(g.log_scale[i]);
  for (int i = 0; i < 4; ++i) add_f(g.rotation[i]);
  add_f(g.opacity_logit);
  for (int i = 0; i < 3; ++i) add_f(g.sh_dc[i]);
  for (const auto& c : g.sh_rest)
    for (int i = 0; i < 3; ++i) add_f(c[i]);
  add(to_underlying(g.id));
  add(static_cast<std::uint32_t>(to_underlying(g.object)));
  add(g.support);
  add(g.carrier ? 1u : 0u);
  return h;
}

Expected<SlotTable> SlotTable::create(std::uint32_t capacity) {
  if (capacity == 0) return Error{"slot table: capacity 0 (a client must hold at least one Gaussian)"};
  if (capacity > kMaxSlotCapacity)
    return Error{"slot table: capacity " + std::to_string(capacity) + " exceeds the maximum " +
                 std::to_string(kMaxSlotCapacity)};
  return SlotTable(capacity);
}

SlotTable::SlotTable(std::uint32_t capacity)
    : slot_ids_(capacity, kEmpty), records_(capacity), dirty_(capacity, 0) {
  free_.resize(capacity);
  // Stack top is the back: push high slots first so slot 0 is handed out first and the
  // resident set stays packed at the front of the buffer.
  for (std::uint32_t i = 0; i < capacity; ++i) free_[i] = capacity - 1 - i;
  index_.reserve(capacity);
}

void SlotTable::mark_dirty(std::uint32_t slot) {
  if (!dirty_[slot]) {
    dirty_[slot] = 1;
    dirty_list_.push_back(slot);
  }
}

Expected<SlotIndex> SlotTable::insert(GaussianId id, const Gaussian& value) {
  if (to_underlying(id) == kEmpty) return Error{"slot table: id " + id_text(id) + " is reserved"};
  if (free_.empty()) return Error{"slot table: full (" + std::to_string(capacity()) + " slots) inserting id " + id_text(id)};
  if (const std::uint32_t* held = index_.find(to_underlying(id)))
    return Error{"slot table: id " + id_text(id) + " already holds slot " + std::to_string(*held)};
  const std::uint32_t slot = free_.back();
  free_.pop_back();
  index_.set(to_underlying(id), slot);
  slot_ids_[slot] = to_underlying(id);
  records_[slot] = value;
  mark_dirty(slot);
  return SlotIndex{slot};
}

Status SlotTable::update(GaussianId id, const Gaussian& value) {
  const std::uint32_t* slot = index_.find(to_underlying(id));
  if (!slot) return Error{"slot table: update of non-resident id " + id_text(id)};
  records_[*slot] = value;
  mark_dirty(*slot);
  return Ok{};
}

Status SlotTable::remove(GaussianId id) {
  const std::uint32_t* found = index_.find(to_underlying(id));
  if (!found) return Error{"slot table: remove of non-resident id " + id_text(id)};
  const std::uint32_t slot = *found;
  index_.erase(to_underlying(id));
  slot_ids_[slot] = kEmpty;
  // An empty record (opacity logit -inf would be NaN-prone on GPUs; zero scale and the
  // renderer's empty-slot check are what skip it).
  records_[slot] = Gaussian{};
  records_[slot].opacity_logit = -1e4f;
  records_[slot].log_scale = glm::vec3(-1e4f);
  free_.push_back(slot);
  mark_dirty(slot);
  return Ok{};
}

Expected<SlotIndex> SlotTable::replace(GaussianId leaving, GaussianId entering, const Gaussian& value) {
  const std::uint32_t* found = index_.find(to_underlying(leaving));
  if (!found) return Error{"slot table: replace of non-resident id " + id_text(leaving)};
  if (to_underlying(entering) == kEmpty) return Error{"slot table: id " + id_text(entering) + " is reserved"};
  if (leaving != entering && index_.find(to_underlying(entering)) != nullptr)
    return Error{"slot table: replace into id " + id_text(entering) + " that is already resident"};
  const std::uint32_t slot = *found;
  index_.erase(to_underlying(leaving));
  index_.set(to_underlying(entering), slot);
  slot_ids_[slot] = to_underlying(entering);
  records_[slot] = value;
  mark_dirty(slot);
  return SlotIndex{slot};
}

SlotIndex SlotTable::slot_of(GaussianId id) const {
  const std::uint32_t* slot = index_.find(to_underlying(id));
  return slot ? SlotIndex{*slot} : kNoSlot;
}

bool SlotTable::occupant(SlotIndex slot, GaussianId& out_id) const {
  const auto s = to_underlying(slot);
  if (s >= slot_ids_.size() || slot_ids_[s] == kEmpty) return false;
  out_id = GaussianId{slot_ids_[s]};
  return true;
}

std::vector<GaussianId> SlotTable::occupants() const {
  std::vector<GaussianId> out;
  out.reserve(size());
  for (const auto id : slot_ids_)
    if (id != kEmpty) out.push_back(GaussianId{id});
  return out;
}

std::vector<SlotRange> SlotTable::take_dirty_ranges(std::uint32_t max_gap) {
  std::sort(dirty_list_.begin(), dirty_list_.end());
  std::vector<SlotRange> ranges;
  for (std::uint32_t s : dirty_list_) {
    dirty_[s] = 0;
    if (!ranges.empty()) {
      SlotRange& last = ranges.back();
      const std::uint64_t end = std::uint64_t{last.first} + last.count;  // one past the last
      if (std::uint64_t{s} <= end + max_gap) {
        last.count = s + 1 - last.first;
        continue;
      }
    }
    ranges.push_back({s, 1});
  }
  dirty_list_.clear();
  return ranges;
}

Status SlotTable::check() const {
  std::vector<std::uint8_t> seen(capacity(), 0);
  std::string problem;
  index_.for_each([&](std::uint64_t key, std::uint32_t slot) {
    if (!problem.empty()) return;
    const GaussianId id{key};
    if (slot >= capacity()) {
      problem = "slot table: id " + id_text(id) + " maps to slot " + std::to_string(slot) + " beyond capacity";
    } else if (seen[slot]) {
      problem = "slot table: slot " + std::to_string(slot) + " used twice";
    } else if (slot_ids_[slot] != key) {
      problem = "slot table: slot " + std::to_string(slot) + " records a different id than id " + id_text(id);
    }
    if (slot < capacity()) seen[slot] = 1;
  });
  if (!problem.empty()) return Error{problem};
  for (std::uint32_t s : free_) {
    if (s >= capacity()) return Error{"slot table: free slot " + std::to_string(s) + " beyond capacity"};
    if (seen[s] == 1) return Error{"slot table: slot " + std::to_string(s) + " is both used and free"};
    if (seen[s] == 2) return Error{"slot table: slot " + std::to_string(s) + " is free twice"};
    if (slot_ids_[s] != kEmpty) return Error{"slot table: free slot " + std::to_string(s) + " still names an id"};
    seen[s] = 2;
  }
  if (index_.size() + free_.size() != capacity())
    return Error{"slot table: " + std::to_string(index_.size()) + " used + " + std::to_string(free_.size()) +
                 " free != capacity " + std::to_string(capacity())};
  return Ok{};
}

}  // namespace gauss
