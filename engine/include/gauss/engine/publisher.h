#pragma once
// Publisher: once per display frame, moves pending edits from the DesiredState into
// the SlotTable (the published state) under a work allowance.
//   immediate:   every pending edit, now.
//   progressive: the highest-priority pending edits up to the allowance. Priority mixes
//                reconstruction support, relevance to the current view, change magnitude
//                and age. The allowance adapts to recent display slack within bounds, and
//                an age escape serves edits older than a limit even at low priority.
// The published total never exceeds the SlotTable's capacity: an insert that finds no
// free slot takes over the slot of a pending remove (one slot write, like Replace).
//
// Cost per frame is bounded by the allowance, not by what is pending (a far teleport
// leaves ~2M edits pending for many frames). Progressive publication keeps a ranking:
// a small sorted head it serves from, an unsorted backlog it refills the head from by
// selection, and a queue in arrival (= age) order for the age escape. Edits that become
// pending are scored once on arrival (DesiredState::take_pending_arrivals); the backlog
// is re-scored a slice per frame, the head every frame, so the ranking follows the view
// and the age term with a lag of a few frames instead of a full re-rank per frame.
// Every ranked item is checked against its entry when used: one that stopped being
// pending, or whose entry now holds another id, is dropped.
#include <cstdint>
#include <deque>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/desired_state.h"
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
  // Priority weights (each term lies in [0, 1]).
  float w_support{0.2f};
  float w_view{0.5f};
  float w_magnitude{0.2f};
  float w_age{0.1f};
  float support_reference{32.0f};  // support at which the support term saturates
  float age_reference_s{1.0f};     // age at which the age term saturates
  float view_distance_reference{4.0f};  // metres: relevance halves at this distance
  float view_cos_half_fov{0.5f};   // cos of the half field of view counted as "in view"
  // Ranking upkeep: backlog entries re-scored per frame (the ranking's lag behind the view
  // is backlog / this, in frames), and the head's size in allowances.
  std::uint32_t rescore_per_frame{4096};
  std::uint32_t head_allowances{4};
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
  std::uint32_t allowance{0};  // allowance in force this frame (0 = unbounded)
  std::uint32_t new_ranges{0}; // writes that opened an upload range (counted when range_cost > 0)
  std::uint32_t pending_after{0};
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
  float priority(const DesiredEntry& e, const ViewState& view, double now) const;
  // The view term of the priority in [0, 1]: in view and near scores high.
  float view_relevance(const DesiredEntry& e, const ViewState& view) const;
  // Inside the cone of half-angle acos(view_cos_half_fov) around the view direction.
  bool in_view_cone(const glm::vec3& position, const ViewState& view) const;

 private:
  Status publish_entry(DesiredState& desired, SlotTable& slots, std::uint32_t index, PublishReport& rep);
  void count_range(const SlotTable& slots, SlotIndex slot, PublishReport& rep) const;
  // Allowance units used this frame (writes and ranges beyond the age escape).
  double charged_work(const PublishReport& rep) const;
  bool over_budget(const PublishReport& rep) const;
  // A ranked pending entry. `key` orders the selection: descending priority, then slot
  // (so equal priorities vacate runs of slots), then entry index. `spare_key` orders
  // removes as room for inserts: least visible first, then by slot.
  struct Ranked {
    std::uint64_t key{0};
    std::uint64_t spare_key{0};
    std::uint32_t index{0};
    PendingKind kind{PendingKind::None};
    GaussianId id{0};
  };
  static bool before(const Ranked& a, const Ranked& b) { return a.key != b.key ? a.key < b.key : a.index < b.index; }
  struct Aged {
    double since{0.0};
    std::uint32_t index{0};
    GaussianId id{0};
  };
  Ranked rank(const DesiredState& desired, const SlotTable& slots, std::uint32_t index, double now) const;
  bool still_pending(const DesiredState& desired, std::uint32_t index, GaussianId id) const;
  void rebuild_ranking(const DesiredState& desired, const SlotTable& slots, double now);
  void update_ranking(DesiredState& desired, const SlotTable& slots, double now);
  void rescore_head(const DesiredState& desired, const SlotTable& slots, double now);
  bool refill_head(const DesiredState& desired);
  void refill_spares(const DesiredState& desired, PendingKind kind, std::size_t need);
  // Publishes `chosen` (entry indices), pairing inserts with removes as described in
  // publisher.cpp; stops at the frame's budget.
  Status apply_chosen(DesiredState& desired, SlotTable& slots, const std::vector<std::uint32_t>& chosen, PublishReport& rep);
  std::uint32_t next_spare(const DesiredState& desired, PendingKind kind, std::size_t need);

  PublisherConfig config_;
  std::uint32_t allowance_;
  double slack_{0.5};
  bool saturated_{false};  // the last progressive frame used its whole allowance
  double range_fraction_{1.0};  // new ranges per slot write in the last busy frame
  double budget_{0.0};          // allowance units apply_chosen may use this frame (0 = no limit)
  std::uint32_t escaped_ranges_{0};  // ranges opened by this frame's age escape
  ViewState view_;                      // this frame's view
  // The ranking (progressive mode only; rebuilt after immediate frames).
  bool ranked_{false};
  std::vector<Ranked> head_;       // ascending key from head_pos_
  std::size_t head_pos_{0};
  ViewState head_view_;            // the view the head was scored for
  std::vector<Ranked> backlog_;    // unsorted
  std::size_t rescore_cursor_{0};
  std::vector<Ranked> spare_removes_, spare_inserts_;  // the next one to use at the back
  std::deque<Aged> by_age_;        // ascending `since`
  std::vector<std::uint32_t> arrivals_, chosen_;
  std::vector<std::uint32_t> chosen_stamp_;  // per entry index: the round that chose it
  std::uint32_t round_{0};
};

}  // namespace gauss
