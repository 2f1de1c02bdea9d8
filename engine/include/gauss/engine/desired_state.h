#pragma once
// DesiredState: the client's newest desired record per persistent id, kept apart from
// what is published (resident in GPU slots). Received edits are coalesced by latest
// value: a newer value replaces an older pending one, a remove after a pending
// (unpublished) insert cancels both, so the client converges straight to the newest
// target without publishing intermediate states.
//
// Contract of a batch: edits apply in order. Each edit that is wrong is rejected and
// counted (reason in stats and the first message), the state of its id untouched:
//   - insert of an id already desired, update/remove/replace of an id never inserted
//     (or already removed), a replace whose entering id is already desired;
//   - a record with a non-finite field;
//   - an insert that would make the desired set larger than the capacity M at that
//     point (the host's differ emits removes before inserts, or Replace).
// A whole batch is rejected, state untouched, when its epoch goes backwards.
// Epochs: batches arrive in non-decreasing epoch order. The first batch of epoch e
// carries every scene change of epoch e for this client (possibly none); later batches
// of the same epoch carry selection changes only (the pose or query moved, the scene
// did not), so receiving a batch of epoch e means every scene edit of epochs <= e has
// arrived.
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/edit.h"
#include "gauss/engine/gaussian.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/result.h"

namespace gauss {

namespace detail {

// IdIndex: GaussianId -> entry index, an open-addressing hash table with linear
// probing and backward-shift deletion. The client's coalescing does one lookup per
// received edit into a table of up to M ids; std::unordered_map costs a node (a second
// cache miss) per lookup, this costs one probe run in two flat arrays.
// The id 2^64 - 1 marks an empty cell and cannot be stored (DesiredState rejects it).

class IdIndex {
 public:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};

  std::size_t size() const noexcept { return count_; }

  // Pointer to the value of key, or nullptr.
  std::uint32_t* find(std::uint64_t key) {
    if (keys_.empty()) return nullptr;
    for (std::size_t i = slot(key);; i = (i + 1) & mask_) {
      if (keys_[i] == key) return &vals_[i];
      if (keys_[i] == kEmpty) return nullptr;
    }
  }
  const std::uint32_t* find(std::uint64_t key) const { return const_cast<IdIndex*>(this)->find(key); }

  // Inserts or overwrites.
  void set(std::uint64_t key, std::uint32_t value) {
    if ((count_ + 1) * 2 > keys_.size()) grow();
    for (std::size_t i = slot(key);; i = (i + 1) & mask_) {
      if (keys_[i] == key) {
        vals_[i] = value;
        return;
      }
      if (keys_[i] == kEmpty) {
        keys_[i] = key;
        vals_[i] = value;
        ++count_;
        return;
      }
    }
  }

  // Removes key if present. Backward shift keeps every probe run unbroken.
  void erase(std::uint64_t key) {
    if (keys_.empty()) return;
    std::size_t i = slot(key);
    while (keys_[i] != key) {
      if (keys_[i] == kEmpty) return;
      i = (i + 1) & mask_;
    }
    for (std::size_t j = (i + 1) & mask_;; j = (j + 1) & mask_) {
      if (keys_[j] == kEmpty) break;
      const std::size_t home = slot(keys_[j]);
      // Move j back to i when i lies cyclically in [home, j).
      if (((j - home) & mask_) >= ((j - i) & mask_)) {
        keys_[i] = keys_[j];
        vals_[i] = vals_[j];
        i = j;
      }
    }
    keys_[i] = kEmpty;
    --count_;
  }

  void reserve(std::size_t n) {
    while (n * 2 > keys_.size()) grow();
  }

  template <class F>
  void for_each(F&& f) const {
    for (std::size_t i = 0; i < keys_.size(); ++i)
      if (keys_[i] != kEmpty) f(keys_[i], vals_[i]);
  }

 private:
  std::size_t slot(std::uint64_t key) const {
    // Fibonacci hashing: host ids are often dense runs; multiply-shift spreads them.
    return static_cast<std::size_t>((key * 0x9e3779b97f4a7c15ull) >> shift_) & mask_;
  }
  void grow() {
    std::vector<std::uint64_t> old_keys;
    std::vector<std::uint32_t> old_vals;
    old_keys.swap(keys_);
    old_vals.swap(vals_);
    const std::size_t cap = old_keys.empty() ? 64 : old_keys.size() * 2;
    keys_.assign(cap, kEmpty);
    vals_.assign(cap, 0);
    mask_ = cap - 1;
    int bits = 0;
    while ((std::size_t{1} << bits) < cap) ++bits;
    shift_ = 64 - bits;
    count_ = 0;
    for (std::size_t i = 0; i < old_keys.size(); ++i)
      if (old_keys[i] != kEmpty) set(old_keys[i], old_vals[i]);
  }

  std::vector<std::uint64_t> keys_;
  std::vector<std::uint32_t> vals_;
  std::size_t count_{0};
  std::size_t mask_{0};
  int shift_{64};
};

}  // namespace detail

enum class PendingKind : std::uint8_t { None = 0, Insert, Update, Remove };

// Counters of everything accepted, coalesced and rejected, by reason.
struct DesiredStats {
  std::uint64_t accepted{0};             // edits applied to the desired state
  std::uint64_t superseded{0};           // pending values replaced by a newer one
  std::uint64_t cancelled{0};            // pending inserts cancelled by a remove
  std::uint64_t rejected_unknown_id{0};  // update/remove/replace of an id not desired
  std::uint64_t rejected_duplicate{0};   // insert of an id already desired
  std::uint64_t rejected_bad_value{0};   // non-finite field
  std::uint64_t rejected_capacity{0};    // insert beyond the budget M
  std::uint64_t rejected_batches{0};     // whole batches refused (epoch going backwards)
  std::uint64_t rejected_edits() const {
    return rejected_unknown_id + rejected_duplicate + rejected_bad_value + rejected_capacity;
  }
};

struct ApplyReport {
  std::uint32_t accepted{0};
  std::uint32_t rejected{0};
  std::uint32_t newly_pending{0};  // ids that had nothing pending before this batch
  std::string first_rejection;     // reason of the first rejected edit, empty if none
};

// One persistent id's state. Kept while the id is desired, published or pending.
struct DesiredEntry {
  GaussianId id{0};
  Gaussian value{};                 // newest desired record (last published one after a remove)
  glm::vec3 published_position{0.0f};  // of the published record: view relevance of a remove
  Epoch epoch{0};                   // epoch of the newest edit of this id
  double pending_since{0.0};        // when the id first had something pending (age)
  float magnitude{0.0f};            // change size of the pending edit in [0, 1]
  bool desired{false};              // in the desired set
  bool published{false};            // resident in a slot
  bool dirty{false};                // desired record differs from the published one
  std::uint32_t pending_pos{kNotPending};  // position in the pending list
  static constexpr std::uint32_t kNotPending = 0xFFFFFFFFu;

  PendingKind pending_kind() const {
    if (desired && !published) return PendingKind::Insert;
    if (!desired && published) return PendingKind::Remove;
    if (desired && dirty) return PendingKind::Update;
    return PendingKind::None;
  }
};

class DesiredState {
 public:
  // capacity = the client's budget M (validated by SlotTable::create beforehand).
  explicit DesiredState(std::uint32_t capacity);

  // Applies one received batch at time `now` (seconds, for the age of pending edits).
  // Error (state untouched) only when the whole batch is refused.
  Expected<ApplyReport> apply(const EditBatch& batch, double now);
  // A resynchronisation: `snapshot` is the complete desired set of its epoch (inserts
  // only). Ids desired now but absent from it are removed; ids present with the same
  // record stay published untouched (no flicker on reconnect). Same rejection rules.
  Expected<ApplyReport> apply_resync(const EditBatch& snapshot, double now);

  // Publication side: called by the Publisher after it wrote the entry's slot.
  void mark_published(std::uint32_t entry_index);

  std::uint32_t capacity() const noexcept { return capacity_; }
  std::size_t desired_count() const noexcept { return desired_count_; }
  std::size_t published_count() const noexcept { return published_count_; }
  std::size_t pending_count() const noexcept { return pending_.size(); }
  const std::vector<std::uint32_t>& pending() const noexcept { return pending_; }
  const DesiredEntry& entry(std::uint32_t index) const { return entries_[index]; }
  // Size of the entry pool: every entry index is below this (for per-entry scratch).
  std::size_t entry_slots() const noexcept { return entries_.size(); }
  const DesiredEntry* find(GaussianId id) const;

  // Highest epoch whose batch has arrived (nullopt before the first).
  std::optional<Epoch> received_epoch() const noexcept { return received_; }
  // Highest epoch e such that every received Gaussian edit of epochs <= e has been
  // published or superseded: the Gaussian side of the surface epoch barrier. Never
  // decreases: once epoch e's scene changes are published, a later selection-only
  // batch of the same epoch (records of epoch e) does not make the published state older.
  std::optional<Epoch> published_epoch() const;
  // Epoch of the oldest pending edit (nullopt when nothing is pending).
  std::optional<Epoch> oldest_pending_epoch() const {
    if (epoch_counts_.empty()) return std::nullopt;
    return Epoch{epoch_counts_.begin()->first};
  }

  // Order-independent checksums (see record_hash) of the desired set and of the
  // published set as this state believes it to be.
  std::uint64_t desired_checksum() const;

  const DesiredStats& stats() const noexcept { return stats_; }

  // Internal consistency (counts, pending list, epoch histogram). O(n); for tests.
  Status check() const;

 private:
  enum class Op { Insert, Update, Remove };
  // Returns an empty string on success, else the rejection reason.
  std::string apply_one(Op op, GaussianId id, const Gaussian* value, Epoch epoch, double now, ApplyReport& rep);
  std::uint32_t new_entry(GaussianId id);
  void release_entry(std::uint32_t index);
  void refresh_pending(std::uint32_t index, Epoch old_epoch, bool was_pending);
  void count_epoch(Epoch e, int delta);

  std::uint32_t capacity_;
  detail::IdIndex index_;  // id -> entry
  std::vector<DesiredEntry> entries_;
  std::vector<std::uint32_t> free_entries_;
  std::vector<std::uint32_t> pending_;
  // Pending entries per epoch: the oldest pending epoch bounds the barrier. Few distinct
  // epochs are pending at once, so the map stays tiny.
  std::map<std::uint64_t, std::uint32_t> epoch_counts_;
  std::optional<Epoch> received_;
  mutable std::optional<Epoch> published_floor_;  // highest published epoch reported so far
  std::size_t desired_count_{0};
  std::size_t published_count_{0};
  DesiredStats stats_;
};

// Change size of replacing `from` by `to`, in [0, 1]: position shift relative to the
// Gaussian's own size plus colour and opacity change. Drives progressive priority.
float change_magnitude(const Gaussian& from, const Gaussian& to);

bool gaussian_is_finite(const Gaussian& g);

}  // namespace gauss
