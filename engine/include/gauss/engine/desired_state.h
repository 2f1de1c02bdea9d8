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
#include "gauss/engine/id_index.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/result.h"

namespace gauss {


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
  std::uint64_t arrival_overflows{0};    // arrival lists dropped unread (the consumer rescans)
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

// An entry that became pending (or whose pending edit changed), as DesiredState lists it
// for the Publisher: everything its priority reads, so scoring it never touches the entry.
struct PendingArrival {
  glm::vec3 position{0.0f};  // where the edit shows: the new record's, or a remove's published one
  float magnitude{0.0f};     // DesiredEntry::magnitude
  double since{0.0};         // DesiredEntry::pending_since
  GaussianId id{0};
  std::uint32_t index{0};    // entry index
  std::uint32_t support{0};  // of the new record (0 for a remove)
  SlotIndex slot{kNoSlot};   // the slot a remove or update rewrites (kNoSlot for an insert)
  PendingKind kind{PendingKind::None};
  bool changed{false};       // it was pending already: its pending edit changed
  // DesiredState::change_count() just after this change (arrival_of: as of the call). An
  // entry's arrivals reach a consumer out of order (two lists, a rescan of the entries
  // after an overflow) and its index is reused once it is released: a consumer that
  // already ranked or published the entry as of a later count skips the arrival as stale.
  std::uint64_t stamp{0};
};

struct PendingArrivals {
  std::vector<PendingArrival> removes;
  std::vector<PendingArrival> others;  // inserts and updates
  bool overflowed{false};
  // The first take from this DesiredState: the lists hold everything that became pending
  // since it was made (a later consumer would have to rescan pending() instead).
  bool complete{false};
  std::size_t size() const noexcept { return removes.size() + others.size(); }
  void clear() noexcept {
    removes.clear();
    others.clear();
    overflowed = false;
    complete = false;
  }
};

class DesiredState {
 public:
  // capacity = the client's budget M (validated by SlotTable::create beforehand).
  // Allocates (and touches) the id index and the entries for M ids up front, as the
  // SlotTable does for its records: a batch then costs no allocation, no rehash and no
  // first-touch page faults (which were most of the cost of a large insert batch).
  // The arrival lists hold up to 2 x capacity + `arrival_slack` entries between takes.
  explicit DesiredState(std::uint32_t capacity, std::uint32_t arrival_slack = kArrivalSlack);
  static constexpr std::uint32_t kArrivalSlack = 1024;

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
  // the order that happened, moved into `out`: removes and the rest in two lists (a
  // consumer that works through them a slice per frame reaches the inserts of a large
  // batch without first wading through its removes). Each carries what the Publisher
  // scores it by, copied while apply() had the entry in cache; within a list the new
  // ones' `since` ascends. `out.overflowed` says more than twice capacity() arrived
  // between calls and the lists were dropped: the caller must rescan pending(). Lets the
  // Publisher keep its ranking current without reading every pending entry per frame.
  void take_pending_arrivals(PendingArrivals& out);
  // The entry as an arrival (kind None when nothing is pending): what a consumer that
  // lost the lists (an overflow) ranks pending entries by.
  PendingArrival arrival_of(std::uint32_t index) const;
  // Pending changes so far (every one, listed or lost to an overflow): the stamps arrivals
  // carry, so that a consumer can tell an arrival older than what it last saw of an entry.
  std::uint64_t change_count() const noexcept { return changes_; }

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
  std::uint32_t arrival_slack_;
  detail::IdIndex index_;  // id -> entry
  std::vector<DesiredEntry, detail::TableAllocator<DesiredEntry>> entries_;
  std::vector<std::uint32_t> free_entries_;
  std::vector<std::uint32_t> pending_;
  PendingArrivals arrivals_;  // became pending since take_pending_arrivals()
  std::uint64_t changes_{0};  // see change_count()
  bool arrivals_taken_{false};
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
