#pragma once
// Publisher: once per display frame, moves pending edits from the DesiredState into
// the SlotTable (the published state) under a work allowance.
//   immediate:   every pending edit as soon as possible: straight from the arrival
//                lists in arrival order, unscored, at a fixed `immediate_allowance` slot
//                writes per frame (no slack adaptation, no age escape needed), so a batch
//                larger than that is spread over the next frames at that rate instead of
//                stalling one frame; a batch within the allowance is published whole in
//                the next frame, as before.
//   progressive: the highest-priority pending edits up to the allowance. Priority mixes
//                reconstruction support, relevance to the current view, change magnitude
//                and age. The allowance adapts to recent display slack within bounds, and
//                an age escape serves edits older than a limit even at low priority.
// The published total never exceeds the SlotTable's capacity: an insert that finds no
// free slot takes over the slot of a pending remove (one slot write, like Replace).
//
// Cost per frame follows the allowance, never what is pending (a far teleport leaves
// ~400k edits pending at M = 200k, and a backlog of millions must not stall a frame):
//   - arrivals: DesiredState lists what became pending with everything its priority reads
//     (copied on the network thread, while apply() had the entry in cache); a frame ranks
//     a slice of them, a few allowances' worth, removes and the rest from separate lists;
//   - ranking: candidates live in bucket queues by priority (publish_ranking.h), one per
//     kind; a slice is re-scored per frame (the ranking lags the view by backlog / slice
//     frames) and a candidate popped for publication is re-scored first, so one the view
//     left behind goes back down instead of being published;
//   - room: pending removes are also listed by slot within visibility classes, so an insert
//     takes the least visible leaving Gaussian's slot, in slot order, in O(1);
//   - age: the age escape reads queues in ranking order.
// Every candidate carries the entry's sequence number for its pending period and is dropped
// when that changed (published, or pending again): stale candidates cost one counted touch.
// Each frame's work is reported (PublishReport::ranked, touched) so tests bound it.
#include <cstdint>
#include <deque>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/desired_state.h"
#include "gauss/engine/publish_ranking.h"
#include "gauss/engine/slot_table.h"

namespace gauss {

enum class PublishMode : std::uint8_t { Immediate = 0, Progressive = 1 };

struct PublisherConfig {
  PublishMode mode{PublishMode::Progressive};
  // Edits per frame. The allowance starts at `initial` and stays in [min, max].
  std::uint32_t allowance_min{1000};
  std::uint32_t allowance_max{60000};
  std::uint32_t allowance_initial{8000};
  double display_period_s{1.0 / 72.0};  // the frame deadline the slack is measured against
  // Slack = 1 - frame_cost / period, smoothed over ~8 frames. Above `slack_high` the
  // allowance grows by `grow` (only after a frame the allowance limited); below
  // `slack_low` it shrinks by `shrink`.
  double slack_high{0.25};
  double slack_low{0.10};
  double grow{1.25};
  double shrink{0.7};
  double slack_smoothing{0.125};
  // Age escape: pending edits older than this are served ahead of priority order, at
  // most `escape_quota` per frame on top of the allowance.
  double age_escape_s{0.5};
  std::uint32_t escape_quota{2000};
  // Upload ranges: a slot write with no other slot written this frame within
  // `range_gap` slots of it opens a new upload range (a copy command), which costs the
  // frame about as much as `range_cost` slot writes. The allowance is charged for both,
  // so a frame of scattered writes stays within the display budget like a frame of
  // contiguous ones. 0 = charge slot writes only. range_gap should equal the client's
  // range_merge_gap (ClientState sets it so).
  float range_cost{0.0f};
  std::uint32_t range_gap{0};
  // Upload ranges a frame may open at most, age escape included (0 = no cap): what bounds
  // the copy regions of a frame's upload pass when writes scatter (updates all over the
  // table, removes chosen by priority), whatever range_cost says.
  std::uint32_t max_new_ranges{4096};
  // Priority weights (each term lies in [0, 1]).
  float w_support{0.2f};
  float w_view{0.5f};
  float w_magnitude{0.2f};
  float w_age{0.1f};
  float support_reference{32.0f};  // support at which the support term saturates
  float age_reference_s{1.0f};     // age at which the age term saturates
  float view_distance_reference{4.0f};  // metres: relevance halves at this distance
  float view_cos_half_fov{0.5f};   // cos of the half field of view counted as "in view"
  // Ranking upkeep: ranked candidates re-scored per frame (the ranking's lag behind the
  // view is backlog / this, in frames; also the bound on candidates re-scored as they are
  // popped), and arrivals ranked per frame from each of the two arrival lists: the larger
  // of rescore_per_frame and rank_allowances x the allowance in force.
  std::uint32_t rescore_per_frame{4096};
  std::uint32_t rank_allowances{2};
  // Immediate mode's fixed allowance (slot writes per frame).
  std::uint32_t immediate_allowance{60000};
};

struct ViewState {
  glm::vec3 eye{0.0f};
  glm::vec3 forward{0.0f, 0.0f, 1.0f};  // unit, world space
};

struct PublishReport {
  std::uint32_t inserted{0};
  std::uint32_t updated{0};
  std::uint32_t removed{0};
  std::uint32_t replaced{0};   // insert + remove sharing one slot write
  std::uint32_t escaped{0};    // slot writes spent on the age escape
  std::uint32_t allowance{0};  // allowance in force this frame
  std::uint32_t new_ranges{0}; // writes that opened an upload range (counted when range_cost > 0 or max_new_ranges > 0)
  std::uint32_t pending_after{0};
  // Work of the frame's ranking upkeep, each bounded by a few allowances: arrivals (or
  // pending entries rescanned after an arrival overflow) scored, and ranked candidates
  // re-scored, moved, popped or dropped; `backlog` is the candidates held afterwards.
  std::uint32_t ranked{0};
  std::uint32_t touched{0};
  std::uint32_t backlog{0};
  std::uint32_t slot_writes() const { return inserted + updated + removed + replaced; }
  std::uint32_t edits() const { return inserted + updated + removed + 2 * replaced; }
};

class Publisher {
 public:
  explicit Publisher(PublisherConfig config = {});

  // Publishes one frame's edits. `now` in seconds (the clock of DesiredState::apply).
  // Fails only if the slot table and desired state disagree (a bug, named).
  Expected<PublishReport> publish(DesiredState& desired, SlotTable& slots, const ViewState& view, double now);
  // Reports the cost of the last displayed frame (render + publication) so the
  // allowance can follow the display slack.
  void report_frame_cost(double seconds);

  // Switches between immediate and progressive publication from the next frame on.
  void set_mode(PublishMode mode) noexcept { config_.mode = mode; }
  // The display period the slack is measured against (a display that changed rate, or
  // one measured at run time). Ignored unless finite and > 0.
  void set_display_period(double seconds) noexcept {
    if (seconds > 0.0 && seconds < 1e9) config_.display_period_s = seconds;
  }

  std::uint32_t allowance() const noexcept { return allowance_; }
  double smoothed_slack() const noexcept { return slack_; }
  const PublisherConfig& config() const noexcept { return config_; }
  // The view term of the priority in [0, 1] of an edit showing at `position`: in view and
  // near scores high.
  float view_relevance(const glm::vec3& position, const ViewState& view) const;
  // Inside the cone of half-angle acos(view_cos_half_fov) around the view direction.
  bool in_view_cone(const glm::vec3& position, const ViewState& view) const;

 private:
  using Candidate = detail::Candidate;
  struct Aged {
    double since{0.0};
    std::uint32_t index{0};
    std::uint32_t seq{0};
  };
  using ArrivalChunks = std::deque<std::vector<PendingArrival>>;

  Status publish_entry(DesiredState& desired, SlotTable& slots, std::uint32_t index, PublishReport& rep);
  void count_range(const SlotTable& slots, SlotIndex slot, PublishReport& rep) const;
  // Allowance units used this frame (writes and ranges beyond the age escape).
  double charged_work(const PublishReport& rep) const;
  bool over_budget(const PublishReport& rep) const;

  float support_term(std::uint32_t support) const;
  float score(const Candidate& c) const;  // this frame's view and time
  int bucket_of(float priority) const;
  int remove_class(const glm::vec3& position) const;
  Candidate candidate_of(const PendingArrival& a);
  void push_candidate(Candidate c);
  bool live(std::uint32_t index, std::uint32_t seq) const { return index < seq_.size() && seq_[index] == seq; }
  static bool still_pending(const DesiredState& desired, std::uint32_t index, GaussianId id);
  // The entry left its pending period (published): its candidates die, its slot's remove
  // listing goes, and its arrivals from before now (desired.change_count()) are stale.
  void forget(const DesiredState& desired, std::uint32_t index, SlotIndex slot);
  // An arrival older than what was last ranked or published of its entry: ranking it
  // would revive a state the entry left (and kill the live candidate of its real one).
  bool stale(const PendingArrival& a) const { return a.stamp <= seen_[a.index]; }

  void take_arrivals(DesiredState& desired);
  bool has_unranked() const;
  // Ranks up to `budget` arrivals of each list (when `lists`) and of the overflow rescan.
  void rank_arrivals(const DesiredState& desired, std::uint32_t budget, bool lists, PublishReport& rep);
  void rank_entry(const DesiredState& desired, std::uint32_t index);
  void rescore_slice(PublishReport& rep);
  void collect_escapes(const DesiredState& desired, PublishReport& rep);
  // Pops the best candidate still pending, or returns false when none is left.
  bool pop_best(const DesiredState& desired, std::uint32_t& index, PublishReport& rep);
  // Publishes `chosen` (entry indices), pairing inserts with removes as described in
  // publisher.cpp; stops at the frame's budget, or when an insert finds no room yet.
  Status apply_chosen(DesiredState& desired, SlotTable& slots, const std::vector<std::uint32_t>& chosen, PublishReport& rep);
  Status publish_pair(DesiredState& desired, SlotTable& slots, std::uint32_t leaving, std::uint32_t entering,
                      PublishReport& rep);
  Status publish_in_arrival_order(DesiredState& desired, SlotTable& slots, PublishReport& rep);
  const PendingArrival* front_arrival(ArrivalChunks& chunks, std::size_t& pos);
  void retire_chunk(ArrivalChunks& chunks, std::size_t& pos);
  std::uint32_t next_spare_remove(const DesiredState& desired, PublishReport& rep);
  std::uint32_t next_spare_insert(const DesiredState& desired, PublishReport& rep);
  // Chosen entries the frame did not publish are ranked again.
  void rerank_leftovers(const DesiredState& desired, PublishReport& rep);

  PublisherConfig config_;
  std::uint32_t allowance_;
  double slack_{0.5};
  bool saturated_{false};  // the last progressive frame used its whole allowance
  double range_fraction_{1.0};  // new ranges per slot write in the last busy frame
  double budget_{0.0};          // allowance units apply_chosen may use this frame (0 = no limit)
  std::uint32_t escaped_ranges_{0};  // ranges opened by this frame's age escape
  bool blocked_{false};         // an insert found no room while removes were still unranked
  bool started_{false};         // the first frame ranked what was pending before
  ViewState view_;              // this frame's view
  double now_{0.0};             // this frame's time
  float priority_scale_{1.0f};  // buckets per unit of priority
  std::vector<float> support_lut_;  // support_term for small supports

  PendingArrivals taken_;
  std::vector<std::vector<PendingArrival>> spare_chunks_;  // emptied lists, memory kept
  ArrivalChunks incoming_removes_, incoming_others_;  // taken, not yet ranked
  std::size_t removes_pos_{0}, others_pos_{0};        // in the front chunks
  std::vector<std::uint32_t> rescan_;                 // pending entries to rank after an overflow
  std::size_t rescan_pos_{0};
  std::array<detail::BucketQueue, 3> queues_;  // by kind: inserts, updates, removes
  detail::RemoveSlots removes_;
  std::vector<std::uint32_t> seq_;  // per entry index: its live sequence number (0: none)
  std::uint32_t next_seq_{0};
  std::vector<std::uint64_t> seen_;  // per entry index: change count it was last ranked or published at
  // Rescoring cursor: queue, bucket, item.
  int rescore_queue_{0}, rescore_bucket_{-1};
  std::size_t rescore_item_{0};
  std::uint32_t reevaluations_{0};  // candidates re-scored when popped this frame
  std::uint64_t pops_left_{0};      // candidates this frame may still pop
  detail::Ring<Aged> aged_removes_, aged_others_;  // ascending `since` (rescans excepted)
  std::vector<std::uint32_t> chosen_, inserts_, removes_chosen_;
  std::vector<std::uint32_t> chosen_stamp_;  // per entry index: the round that chose it
  std::uint32_t round_{0};
};

}  // namespace gauss
