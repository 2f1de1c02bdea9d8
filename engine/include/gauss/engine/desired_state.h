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

// Allocator for the coalescing tables (id index, entry pool): blocks of 4 MiB and more
// are 2 MiB aligned and, on Linux, advised onto transparent huge pages. Coalescing
// touches one random index cell and one random entry per edit; over hundreds of
// megabytes of 4 KiB pages nearly every touch also misses the TLB, and the page walk
// costs about as much as the miss itself.
void* alloc_table(std::size_t bytes, std::size_t align);
void free_table(void* p, std::size_t bytes, std::size_t align) noexcept;

template <class T>
struct TableAllocator {
  using value_type = T;
  TableAllocator() noexcept = default;
  template <class U>
  TableAllocator(const TableAllocator<U>&) noexcept {}
  T* allocate(std::size_t n) { return static_cast<T*>(alloc_table(n * sizeof(T), alignof(T))); }
  void deallocate(T* p, std::size_t n) noexcept { free_table(p, n * sizeof(T), alignof(T)); }
  template <class U>
  bool operator==(const TableAllocator<U>&) const noexcept { return true; }
};

// IdIndex: GaussianId -> entry index, an open-addressing hash table with linear
// probing and backward-shift deletion. The client's coalescing does one lookup per
// received edit into a table of up to M ids; std::unordered_map costs a node (a second
// cache miss) per lookup, this costs one probe run in one flat array of (key, value)
// cells (key and value side by side: one cache miss per lookup, not two).
// The id 2^64 - 1 marks an empty cell and cannot be stored (DesiredState rejects it).

class IdIndex {
 public:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};

  std::size_t size() const noexcept { return count_; }

  // Pointer to the value of key, or nullptr.
  std::uint32_t* find(std::uint64_t key) {
    if (cells_.empty()) return nullptr;
    for (std::size_t i = slot(key);; i = (i + 1) & mask_) {
      if (cells_[i].key == key) return &cells_[i].value;
      if (cells_[i].key == kEmpty) return nullptr;
    }
  }
  const std::uint32_t* find(std::uint64_t key) const { return const_cast<IdIndex*>(this)->find(key); }

  // Asks the cache for the cell where a lookup of key starts (batched lookups issue
  // this a few edits ahead so the miss overlaps other work).
  // Unconditional on purpose: GCC drops a prefetch guarded by a branch that does
  // nothing else. On an empty table this prefetches data() + 0, which never faults.
  void prefetch(std::uint64_t key) const { __builtin_prefetch(cells_.data() + slot(key), 0, 3); }

  // Inserts or overwrites.
  void set(std::uint64_t key, std::uint32_t value) {
    if ((count_ + 1) * 2 > cells_.size()) grow();
    for (std::size_t i = slot(key);; i = (i + 1) & mask_) {
      if (cells_[i].key == key) {
        cells_[i].value = value;
        return;
      }
      if (cells_[i].key == kEmpty) {
        cells_[i] = Cell{key, value};
        ++count_;
        return;
      }
    }
  }

  // Removes key if present. Backward shift keeps every probe run unbroken.
  void erase(std::uint64_t key) {
    if (cells_.empty()) return;
    std::size_t i = slot(key);
    while (cells_[i].key != key) {
      if (cells_[i].key == kEmpty) return;
      i = (i + 1) & mask_;
    }
    for (std::size_t j = (i + 1) & mask_;; j = (j + 1) & mask_) {
      if (cells_[j].key == kEmpty) break;
      const std::size_t home = slot(cells_[j].key);
      // Move j back to i when i lies cyclically in [home, j).
      if (((j - home) & mask_) >= ((j - i) & mask_)) {
        cells_[i] = cells_[j];
        i = j;
      }
    }
    cells_[i].key = kEmpty;
    --count_;
  }

  void reserve(std::size_t n) {
    while (n * 2 > cells_.size()) grow();
  }

  template <class F>
  void for_each(F&& f) const {
    for (const Cell& c : cells_)
      if (c.key != kEmpty) f(c.key, c.value);
  }

 private:
  struct Cell {
    std::uint64_t key{kEmpty};
    std::uint32_t value{0};
  };

  std::size_t slot(std::uint64_t key) const {
    // Fibonacci hashing: host ids are often dense runs; multiply-shift spreads them.
    return static_cast<std::size_t>((key * 0x9e3779b97f4a7c15ull) >> shift_) & mask_;
  }
  void grow() {
    std::vector<Cell, TableAllocator<Cell>> old;
    old.swap(cells_);
    const std::size_t cap = old.empty() ? 64 : old.size() * 2;
    cells_.assign(cap, Cell{});
    mask_ = cap - 1;
    int bits = 0;
    while ((std::size_t{1} << bits) < cap) ++bits;
    shift_ = 64 - bits;
    count_ = 0;
    for (const Cell& c : old)
      if (c.key != kEmpty) set(c.key, c.value);
  }

  std::vector<Cell, TableAllocator<Cell>> cells_;
  std::size_t count_{0};
  std::size_t mask_{0};
  int shift_{63};  // with mask_ 0 every key maps to cell 0 (and the shift stays defined)
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
// Cache-line aligned with the bookkeeping first: coalescing touches an entry at random
// per edit, and a known line layout lets DesiredState::apply prefetch exactly it.
struct alignas(64) DesiredEntry {
  GaussianId id{0};
  Epoch epoch{0};                   // epoch of the newest edit of this id
  double pending_since{0.0};        // when the id first had something pending (age)
  float magnitude{0.0f};            // change size of the pending edit in [0, 1]
  bool desired{false};              // in the desired set
  bool published{false};            // resident in a slot
  bool dirty{false};                // desired record differs from the published one
  std::uint32_t pending_pos{kNotPending};  // position in the pending list
  glm::vec3 published_position{0.0f};  // of the published record: view relevance of a remove
  SlotIndex slot{kNoSlot};          // slot it is published in, as the Publisher reported it
  // Places `value` so that all but its first 8 bytes fill whole cache lines (1..4):
  // coalescing overwrites those with streaming stores, never reading them first.
  std::uint8_t pad_[4]{};
  Gaussian value{};                 // newest desired record (last published one after a remove)
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
  // Allocates (and touches) the id index and the entries for M ids up front, as the
  // SlotTable does for its records: a batch then costs no allocation, no rehash and no
  // first-touch page faults (which were most of the cost of a large insert batch).
  explicit DesiredState(std::uint32_t capacity);

  // Applies one received batch at time `now` (seconds, for the age of pending edits).
  // Error (state untouched) only when the whole batch is refused.
  Expected<ApplyReport> apply(const EditBatch& batch, double now);
  // A resynchronisation: `snapshot` is the complete desired set of its epoch (inserts
  // only). Ids desired now but absent from it are removed; ids present with the same
  // record stay published untouched (no flicker on reconnect). Same rejection rules.
  Expected<ApplyReport> apply_resync(const EditBatch& snapshot, double now);
  // The host restarted (a Welcome of another host session): epochs count again from the
  // new session's start, so the received epoch and the published floor are forgotten
  // (published_epoch() is nullopt until the new session's resync arrives; the resync is
  // then accepted whatever its epoch). The desired set, the published set and what is
  // pending stay: the resync reconciles them id by id.
  void restart_epochs();

  // Publication side: called by the Publisher after it wrote the entry's slot, with
  // that slot when the entry is (still) published afterwards.
  void mark_published(std::uint32_t entry_index, SlotIndex slot = kNoSlot);

  std::uint32_t capacity() const noexcept { return capacity_; }
  std::size_t desired_count() const noexcept { return desired_count_; }
  std::size_t published_count() const noexcept { return published_count_; }
  std::size_t pending_count() const noexcept { return pending_.size(); }
  const std::vector<std::uint32_t>& pending() const noexcept { return pending_; }
  const DesiredEntry& entry(std::uint32_t index) const { return entries_[index]; }
  // Size of the entry pool: every entry index is below this (for per-entry scratch).
  std::size_t entry_slots() const noexcept { return entries_.size(); }
  const DesiredEntry* find(GaussianId id) const;
  // Entries that became pending, or whose pending edit changed, since the last call, in
  // the order that happened, moved into `out`. A changed one carries kArrivalChanged; the
  // others' pending_since ascends. `overflowed` says more than twice capacity() arrived
  // between calls and the list was dropped: the caller must rescan pending(). Lets the
  // Publisher keep its ranking current without scanning every pending entry per frame.
  static constexpr std::uint32_t kArrivalChanged = 0x80000000u;
  void take_pending_arrivals(std::vector<std::uint32_t>& out, bool& overflowed);

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
    return Epoch{epoch_counts_.front().epoch};
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
  std::vector<DesiredEntry, detail::TableAllocator<DesiredEntry>> entries_;
  std::vector<std::uint32_t> free_entries_;
  std::vector<std::uint32_t> pending_;
  std::vector<std::uint32_t> arrivals_;  // became pending since take_pending_arrivals()
  bool arrivals_overflowed_{false};
  // Pending entries per epoch, ascending by epoch: the oldest pending epoch bounds the
  // barrier. Few distinct epochs are pending at once and nearly every edit counts into
  // the newest, so a flat vector searched from the back beats a map (two tree walks per
  // edit).
  struct EpochCount {
    std::uint64_t epoch;
    std::uint32_t count;
  };
  std::vector<EpochCount> epoch_counts_;
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
