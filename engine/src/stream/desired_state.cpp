#include "gauss/engine/desired_state.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <map>
#include <unordered_set>

#include <glm/geometric.hpp>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <cstdlib>
#include <new>

#include "gauss/engine/slot_table.h"
#include "gauss/engine/log_text.h"
#include "gauss/engine/system_memory.h"

namespace gauss {

namespace detail {

namespace {
constexpr std::size_t kHugePage = std::size_t{2} << 20;
constexpr std::size_t kHugeFrom = std::size_t{4} << 20;  // smaller tables stay on ordinary pages
}  // namespace

void* alloc_table(std::size_t bytes, std::size_t align) {
  if (bytes < kHugeFrom) return ::operator new(bytes, std::align_val_t{std::max(align, alignof(std::max_align_t))});
  const std::size_t rounded = (bytes + kHugePage - 1) / kHugePage * kHugePage;
  void* p = std::aligned_alloc(kHugePage, rounded);
  if (!p) throw std::bad_alloc();
  advise_huge_pages(p, rounded);  // advice only: ordinary pages if refused
  return p;
}

void free_table(void* p, std::size_t bytes, std::size_t align) noexcept {
  if (!p) return;
  if (bytes < kHugeFrom) {
    ::operator delete(p, std::align_val_t{std::max(align, alignof(std::max_align_t))});
    return;
  }
  std::free(p);
}

}  // namespace detail

namespace {

bool same_record(const Gaussian& a, const Gaussian& b) { return a.id == b.id && same_value(a, b); }

// Stores a received record into its entry. Coalescing writes records at random over an
// entry pool far larger than the cache; an ordinary store first reads each line it
// partly writes (read-for-ownership), so a 264-byte record costs five line reads before
// its five writes. Streaming stores write the four whole lines without reading them.
// Weakly ordered: DesiredState::apply fences before it returns.
static_assert((offsetof(DesiredEntry, value) + 8) % 64 == 0 && sizeof(Gaussian) - 8 == 256 &&
                  alignof(DesiredEntry) == 64,
              "DesiredEntry layout: value bytes 8..264 must be exactly cache lines 1..4");
void store_value(DesiredEntry& e, const Gaussian& v) {
#if defined(__SSE2__)
  std::memcpy(static_cast<void*>(&e.value), &v, 8);
  const char* src = reinterpret_cast<const char*>(&v) + 8;
  char* dst = reinterpret_cast<char*>(&e.value) + 8;
  for (int i = 0; i < 16; ++i)
    _mm_stream_si128(reinterpret_cast<__m128i*>(dst) + i, _mm_loadu_si128(reinterpret_cast<const __m128i*>(src) + i));
#else
  e.value = v;
#endif
}

void store_fence() {
#if defined(__SSE2__)
  _mm_sfence();
#endif
}

// Counts one edit of a batch in its report: accepted (empty reason) or rejected, keeping
// the first rejection's reason.
void note(ApplyReport& rep, std::string reason) {
  if (reason.empty()) {
    ++rep.accepted;
    return;
  }
  ++rep.rejected;
  if (rep.first_rejection.empty()) rep.first_rejection = std::move(reason);
}

}  // namespace

// The float fields of a Gaussian form one block from `position` to the end of `sh_rest`;
// checking the block's exponent bits in one branch-free pass is what lets coalescing
// validate every received record at millions per second.
static_assert(offsetof(Gaussian, position) == 0 &&
              offsetof(Gaussian, sh_rest) + sizeof(Gaussian::sh_rest) == (3 + 3 + 4 + 1 + 3 + 3 * kMaxShRest) * sizeof(float),
              "Gaussian's float fields are no longer one contiguous block: update gaussian_is_finite");

bool gaussian_is_finite(const Gaussian& g) {
  constexpr std::size_t kFloats = 3 + 3 + 4 + 1 + 3 + 3 * kMaxShRest;
  std::uint32_t bits[kFloats];
  std::memcpy(bits, &g, sizeof(bits));
  std::uint32_t bad = 0;
  // All exponent bits set = infinity or NaN.
  for (std::uint32_t b : bits) bad |= static_cast<std::uint32_t>((b & 0x7f800000u) == 0x7f800000u);
  return bad == 0;
}

float change_magnitude(const Gaussian& from, const Gaussian& to) {
  // Shift measured in the Gaussian's own largest axis: moving a 1 cm splat by 1 cm is a
  // big visible change, moving a 50 cm splat by 1 cm is not.
  const float size = std::exp(std::max({to.log_scale.x, to.log_scale.y, to.log_scale.z, -10.0f}));
  const float shift = glm::length(to.position - from.position) / std::max(size, 1e-4f);
  const float colour = glm::length(to.sh_dc - from.sh_dc);  // SH DC units (~0.28 per unit of RGB)
  const float opacity = std::abs(to.opacity_logit - from.opacity_logit) * 0.25f;
  const float m = shift + colour + opacity;
  return std::isfinite(m) ? std::min(1.0f, m) : 1.0f;
}

DesiredState::DesiredState(std::uint32_t capacity, std::uint32_t arrival_slack)
    : capacity_(capacity), arrival_slack_(arrival_slack) {
  index_.reserve(capacity);
  entries_.resize(capacity);
  free_entries_.resize(capacity);
  // LIFO free list handing out low indices first: a batch of inserts fills the pool in
  // address order.
  for (std::uint32_t i = 0; i < capacity; ++i) free_entries_[i] = capacity - 1 - i;
  pending_.reserve(capacity);
}

const DesiredEntry* DesiredState::find(GaussianId id) const {
  const std::uint32_t* idx = index_.find(to_underlying(id));
  return idx ? &entries_[*idx] : nullptr;
}

std::uint32_t DesiredState::new_entry(GaussianId id) {
  std::uint32_t idx;
  if (!free_entries_.empty()) {
    idx = free_entries_.back();
    free_entries_.pop_back();
    entries_[idx] = DesiredEntry{};
  } else {
    idx = static_cast<std::uint32_t>(entries_.size());
    entries_.emplace_back();
  }
  entries_[idx].id = id;
  index_.set(to_underlying(id), idx);
  return idx;
}

void DesiredState::release_entry(std::uint32_t index) {
  index_.erase(to_underlying(entries_[index].id));
  entries_[index].desired = entries_[index].published = entries_[index].dirty = false;
  free_entries_.push_back(index);
}

void DesiredState::count_epoch(Epoch e, int delta) {
  const std::uint64_t key = to_underlying(e);
  auto it = epoch_counts_.end();
  while (it != epoch_counts_.begin() && std::prev(it)->epoch >= key) --it;
  if (it == epoch_counts_.end() || it->epoch != key) it = epoch_counts_.insert(it, EpochCount{key, 0});
  it->count = static_cast<std::uint32_t>(static_cast<std::int64_t>(it->count) + delta);
  if (it->count == 0) epoch_counts_.erase(it);
}

// Brings the pending list and the epoch histogram in line with the entry's new state.
void DesiredState::refresh_pending(std::uint32_t index, Epoch old_epoch, bool was_pending) {
  DesiredEntry& e = entries_[index];
  const bool now_pending = e.pending_kind() != PendingKind::None;
  if (was_pending) count_epoch(old_epoch, -1);
  if (now_pending) count_epoch(e.epoch, +1);
  if (was_pending && !now_pending) {
    const std::uint32_t pos = e.pending_pos;
    const std::uint32_t moved = pending_.back();
    pending_[pos] = moved;
    entries_[moved].pending_pos = pos;
    pending_.pop_back();
    e.pending_pos = DesiredEntry::kNotPending;
    // The next removal moves the new last entry: fetch its line while this one finishes.
    if (!pending_.empty()) __builtin_prefetch(&entries_[pending_.back()], 1, 1);
  } else if (!was_pending && now_pending) {
    e.pending_pos = static_cast<std::uint32_t>(pending_.size());
    pending_.push_back(index);
  }
  if (now_pending) ++changes_;
  if (!now_pending || arrivals_.overflowed) return;
  // Bounded: a consumer that stops taking arrivals costs a few entries per slot at most.
  if (arrivals_.size() >= 2 * static_cast<std::size_t>(capacity_) + arrival_slack_) {
    arrivals_.clear();
    arrivals_.overflowed = true;
    ++stats_.arrival_overflows;
    return;
  }
  PendingArrival a = arrival_of(index);
  a.changed = was_pending;
  (a.kind == PendingKind::Remove ? arrivals_.removes : arrivals_.others).push_back(a);
}

PendingArrival DesiredState::arrival_of(std::uint32_t index) const {
  const DesiredEntry& e = entries_[index];
  PendingArrival a;
  a.kind = e.pending_kind();
  a.position = a.kind == PendingKind::Remove ? e.published_position : e.value.position;
  a.magnitude = e.magnitude;
  a.since = e.pending_since;
  a.id = e.id;
  a.index = index;
  a.support = a.kind == PendingKind::Remove ? 0u : e.value.support;
  a.slot = a.kind == PendingKind::Insert ? kNoSlot : e.slot;
  a.stamp = changes_;
  return a;
}

void DesiredState::take_pending_arrivals(PendingArrivals& out) {
  out.clear();
  std::swap(out, arrivals_);
  out.complete = !arrivals_taken_ && !out.overflowed;
  arrivals_taken_ = true;
}

std::string DesiredState::apply_one(Op op, GaussianId id, const Gaussian* value, Epoch epoch, double now,
                                    ApplyReport& rep) {
  if (value && !gaussian_is_finite(*value)) {
    ++stats_.rejected_bad_value;
    return "id " + id_text(id) + ": record has a non-finite field";
  }
  if (to_underlying(id) == detail::IdIndex::kEmpty) {
    ++stats_.rejected_unknown_id;
    return "id " + id_text(id) + " is reserved";
  }
  const std::uint32_t* found = index_.find(to_underlying(id));
  std::uint32_t idx = found ? *found : DesiredEntry::kNotPending;
  if (op == Op::Insert) {
    if (found && entries_[idx].desired) {
      ++stats_.rejected_duplicate;
      return "insert of id " + id_text(id) + " that is already desired";
    }
    if (desired_count_ >= capacity_) {
      ++stats_.rejected_capacity;
      return "insert of id " + id_text(id) + " beyond the capacity " + std::to_string(capacity_);
    }
  } else if (!found || !entries_[idx].desired) {
    ++stats_.rejected_unknown_id;
    return std::string(op == Op::Update ? "update" : "remove") + " of id " + id_text(id) + " that is not desired";
  }

  bool was_pending = false;
  Epoch old_epoch{0};
  if (idx == DesiredEntry::kNotPending) {
    idx = new_entry(id);
  } else {
    was_pending = entries_[idx].pending_kind() != PendingKind::None;
    old_epoch = entries_[idx].epoch;
  }
  DesiredEntry& e = entries_[idx];
  if (!was_pending) {
    e.pending_since = now;
    e.magnitude = 0.0f;
    ++rep.newly_pending;
  }
  switch (op) {
    case Op::Insert:
      // Either a fresh id, or a published id whose pending remove this insert supersedes.
      if (was_pending) ++stats_.superseded;
      e.magnitude = e.published ? std::max(e.magnitude, change_magnitude(e.value, *value)) : 1.0f;
      store_value(e, *value);
      e.desired = true;
      e.dirty = true;
      ++desired_count_;
      break;
    case Op::Update:
      if (was_pending) ++stats_.superseded;
      e.magnitude = e.published ? std::max(e.magnitude, change_magnitude(e.value, *value)) : 1.0f;
      store_value(e, *value);
      e.dirty = true;
      break;
    case Op::Remove:
      e.desired = false;
      e.dirty = false;
      --desired_count_;
      if (!e.published) {
        // Remove after a pending insert: both vanish, nothing ever reaches a slot.
        ++stats_.cancelled;
        e.epoch = epoch;
        refresh_pending(idx, old_epoch, was_pending);
        release_entry(idx);
        ++stats_.accepted;
        return {};
      }
      if (was_pending) ++stats_.superseded;
      e.magnitude = 1.0f;
      break;
  }
  e.epoch = epoch;
  refresh_pending(idx, old_epoch, was_pending);
  ++stats_.accepted;
  return {};
}

Expected<ApplyReport> DesiredState::apply(const EditBatch& batch, double now) {
  if (received_ && to_underlying(batch.epoch) < to_underlying(*received_)) {
    ++stats_.rejected_batches;
    return Error{"edit batch of epoch " + std::to_string(to_underlying(batch.epoch)) +
                 " refused: epoch goes backwards (last received " + std::to_string(to_underlying(*received_)) + ")"};
  }
  ApplyReport rep;
  // Software pipeline over the batch: the id index cell of the edit kIndexAhead ahead
  // and the entry of the edit kEntryAhead ahead are requested from memory while this
  // edit is applied. An edit to a random id otherwise waits for two cache misses in a
  // row (index cell, then entry), which bounds coalescing at a few million edits/s.
  // Only a hint: an edit in between may move the entry, the lookup below is exact.
  constexpr std::size_t kIndexAhead = 16;
  constexpr std::size_t kEntryAhead = 8;
  const std::vector<Edit>& edits = batch.edits;
  for (std::size_t k = 0; k < edits.size(); ++k) {
    if (k + kIndexAhead < edits.size()) index_.prefetch(to_underlying(edits[k + kIndexAhead].id));
    if (k + kEntryAhead < edits.size()) {
      if (const std::uint32_t* ahead = index_.find(to_underlying(edits[k + kEntryAhead].id))) {
        // Line 0 holds the bookkeeping, line 1 what change_magnitude reads of the old
        // record; the rest of the record is overwritten by streaming stores, unread.
        const char* line = reinterpret_cast<const char*>(&entries_[*ahead]);
        __builtin_prefetch(line, 1, 1);
        __builtin_prefetch(line + 64, 1, 1);
      }
    }
    const Edit& ed = edits[k];
    switch (ed.kind) {
      case EditKind::Insert: note(rep, apply_one(Op::Insert, ed.id, &ed.value, batch.epoch, now, rep)); break;
      case EditKind::Update: note(rep, apply_one(Op::Update, ed.id, &ed.value, batch.epoch, now, rep)); break;
      case EditKind::Remove: note(rep, apply_one(Op::Remove, ed.id, nullptr, batch.epoch, now, rep)); break;
      case EditKind::Replace: {
        // Validate both halves first so a bad replace changes nothing.
        const DesiredEntry* leaving = find(ed.leaving);
        const DesiredEntry* entering = find(ed.id);
        std::string reason;
        if (!gaussian_is_finite(ed.value)) {
          ++stats_.rejected_bad_value;
          reason = "replace into id " + id_text(ed.id) + ": record has a non-finite field";
        } else if (!leaving || !leaving->desired) {
          ++stats_.rejected_unknown_id;
          reason = "replace of id " + id_text(ed.leaving) + " that is not desired";
        } else if (ed.leaving != ed.id && entering && entering->desired) {
          ++stats_.rejected_duplicate;
          reason = "replace into id " + id_text(ed.id) + " that is already desired";
        }
        if (!reason.empty()) {
          note(rep, std::move(reason));
          break;
        }
        if (ed.leaving == ed.id) {
          note(rep, apply_one(Op::Update, ed.id, &ed.value, batch.epoch, now, rep));
          break;
        }
        ApplyReport inner;
        (void)apply_one(Op::Remove, ed.leaving, nullptr, batch.epoch, now, inner);
        --stats_.accepted;  // the two halves count as one edit
        note(rep, apply_one(Op::Insert, ed.id, &ed.value, batch.epoch, now, rep));
        rep.newly_pending += inner.newly_pending;
        break;
      }
      default:
        ++stats_.rejected_unknown_id;
        note(rep, "edit of id " + id_text(ed.id) + " has an unknown kind " + std::to_string(static_cast<int>(ed.kind)));
    }
  }
  received_ = batch.epoch;
  store_fence();
  return rep;
}

Expected<ApplyReport> DesiredState::apply_resync(const EditBatch& snapshot, double now) {
  if (received_ && to_underlying(snapshot.epoch) < to_underlying(*received_)) {
    ++stats_.rejected_batches;
    return Error{"resync snapshot of epoch " + std::to_string(to_underlying(snapshot.epoch)) +
                 " refused: older than the last received epoch " + std::to_string(to_underlying(*received_))};
  }
  ApplyReport rep;
  std::unordered_set<GaussianId> in_snapshot;
  in_snapshot.reserve(snapshot.edits.size());
  for (const Edit& ed : snapshot.edits)
    if (ed.kind == EditKind::Insert) in_snapshot.insert(ed.id);
  // Drop what the snapshot no longer holds first, so the budget has room for the rest.
  std::vector<GaussianId> stale;
  index_.for_each([&](std::uint64_t id, std::uint32_t idx) {
    if (entries_[idx].desired && !in_snapshot.count(GaussianId{id})) stale.push_back(GaussianId{id});
  });
  for (GaussianId id : stale) {
    ApplyReport inner;
    (void)apply_one(Op::Remove, id, nullptr, snapshot.epoch, now, inner);
    rep.newly_pending += inner.newly_pending;
  }
  std::unordered_set<GaussianId> seen;
  seen.reserve(snapshot.edits.size());
  for (const Edit& ed : snapshot.edits) {
    if (ed.kind != EditKind::Insert) {
      ++stats_.rejected_unknown_id;
      note(rep, "resync snapshot holds a non-insert edit for id " + id_text(ed.id));
      continue;
    }
    if (!seen.insert(ed.id).second) {
      ++stats_.rejected_duplicate;
      note(rep, "resync snapshot names id " + id_text(ed.id) + " twice");
      continue;
    }
    const DesiredEntry* cur = find(ed.id);
    if (cur && cur->desired) {
      if (same_record(cur->value, ed.value)) {
        ++stats_.accepted;
        note(rep, {});
      } else {
        note(rep, apply_one(Op::Update, ed.id, &ed.value, snapshot.epoch, now, rep));
      }
    } else {
      note(rep, apply_one(Op::Insert, ed.id, &ed.value, snapshot.epoch, now, rep));
    }
  }
  // The snapshot is the complete state of its epoch: whatever is still pending is
  // pending towards that epoch.
  epoch_counts_.clear();
  for (std::uint32_t idx : pending_) entries_[idx].epoch = snapshot.epoch;
  if (!pending_.empty()) epoch_counts_.push_back(EpochCount{to_underlying(snapshot.epoch), static_cast<std::uint32_t>(pending_.size())});
  received_ = snapshot.epoch;
  store_fence();
  return rep;
}

void DesiredState::restart_epochs() {
  // Pending entries keep their old epochs (the histogram stays consistent with them)
  // until the resync rebases every pending entry onto its own epoch.
  received_.reset();
  published_floor_.reset();
}

void DesiredState::mark_published(std::uint32_t index, SlotIndex slot) {
  DesiredEntry& e = entries_[index];
  const PendingKind kind = e.pending_kind();
  if (kind == PendingKind::None) return;
  const Epoch old_epoch = e.epoch;
  if (kind == PendingKind::Remove) {
    e.published = false;
    --published_count_;
    refresh_pending(index, old_epoch, true);
    release_entry(index);
    return;
  }
  if (kind == PendingKind::Insert) {
    e.published = true;
    ++published_count_;
  }
  e.dirty = false;
  e.published_position = e.value.position;
  if (slot != kNoSlot) e.slot = slot;
  refresh_pending(index, old_epoch, true);
}

std::optional<Epoch> DesiredState::published_epoch() const {
  std::optional<Epoch> now;
  if (received_) {
    if (epoch_counts_.empty()) {
      now = received_;
    } else if (const std::uint64_t oldest = epoch_counts_.front().epoch; oldest > 0) {
      now = Epoch{oldest - 1};
    }
  }
  if (now && (!published_floor_ || to_underlying(*now) > to_underlying(*published_floor_))) published_floor_ = now;
  return published_floor_;
}

std::uint64_t DesiredState::desired_checksum() const {
  std::uint64_t sum = 0;
  index_.for_each([&](std::uint64_t id, std::uint32_t idx) {
    if (entries_[idx].desired) sum += record_hash(GaussianId{id}, entries_[idx].value);
  });
  return sum;
}

Status DesiredState::check() const {
  std::size_t desired = 0, published = 0, pending = 0;
  std::map<std::uint64_t, std::uint32_t> counts;
  std::string err;
  index_.for_each([&](std::uint64_t raw, std::uint32_t idx) {
    if (!err.empty()) return;
    const GaussianId id{raw};
    const DesiredEntry& e = entries_[idx];
    if (e.id != id) {
      err = "desired state: index of id " + id_text(id) + " points at another entry";
    } else if (!e.desired && !e.published) {
      err = "desired state: id " + id_text(id) + " kept though neither desired nor published";
    }
    desired += e.desired;
    published += e.published;
    const bool is_pending = e.pending_kind() != PendingKind::None;
    if (is_pending) {
      ++pending;
      ++counts[to_underlying(e.epoch)];
      if (e.pending_pos >= pending_.size() || pending_[e.pending_pos] != idx)
        err = "desired state: pending id " + id_text(id) + " missing from the pending list";
    } else if (e.pending_pos != DesiredEntry::kNotPending) {
      err = "desired state: id " + id_text(id) + " listed pending but has nothing pending";
    }
  });
  if (!err.empty()) return Error{err};
  if (desired != desired_count_ || published != published_count_ || pending != pending_.size())
    return Error{"desired state: counts disagree (desired " + std::to_string(desired) + "/" + std::to_string(desired_count_) +
                 ", published " + std::to_string(published) + "/" + std::to_string(published_count_) + ", pending " +
                 std::to_string(pending) + "/" + std::to_string(pending_.size()) + ")"};
  std::map<std::uint64_t, std::uint32_t> held;
  for (std::size_t i = 0; i < epoch_counts_.size(); ++i) {
    if (epoch_counts_[i].count == 0 || (i > 0 && epoch_counts_[i - 1].epoch >= epoch_counts_[i].epoch))
      return Error{"desired state: pending-per-epoch histogram unsorted or holding a zero count"};
    held[epoch_counts_[i].epoch] = epoch_counts_[i].count;
  }
  if (counts != held) return Error{"desired state: pending-per-epoch histogram disagrees"};
  if (desired_count_ > capacity_) return Error{"desired state: " + std::to_string(desired_count_) + " desired exceeds capacity"};
  return Ok{};
}

}  // namespace gauss
