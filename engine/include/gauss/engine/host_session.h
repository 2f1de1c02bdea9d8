#pragma once
// HostSession: the host's side of one client connection, transport-agnostic. The
// transport (net/ over ENet, or the deterministic simulation) feeds it the client's
// decoded messages and sends what it returns; nothing here touches sockets.
//
// Per connection: the Hello check (protocol version, access token, capacity), the
// client's coarse pose and query, its own Selector + Differ (own selection per
// client), the edit batches, surface patches and object-table updates of every epoch.
// A reconnect is a new connection and so a new HostSession: its first batch is a
// resync snapshot (the complete desired set), which the client reconciles with what it
// still holds (DesiredState::apply_resync), so the host never restarts.
//
// Bad input: a message before the Hello, a second Hello, a message of the wrong
// direction, a stale pose, an invalid or too frequent query: each is rejected with a
// reason in the log and a counter; the connection stays, the session state is
// untouched. Only a refused Hello ends the connection (closed() becomes true).
#include <cstdint>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "gauss/engine/codec.h"
#include "gauss/engine/differ.h"
#include "gauss/engine/eligibility.h"
#include "gauss/engine/lod_selector.h"
#include "gauss/engine/messages.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/selector.h"
#include "gauss/engine/stage_events.h"
#include "gauss/engine/wire.h"

namespace gauss {

// A reported head pose within this of where its stillness began counts as held still
// (HostSessionConfig::pose_still_s): a tracked headset at rest or a desktop view not being
// moved stays well inside; a standing user's sway (centimetres, degrees) does not.
inline constexpr double kStillPoseM = 0.002;
inline constexpr double kStillPoseRad = 0.002;

struct HostSessionConfig {
  std::string access_token;          // required token; empty = none required
  std::uint32_t max_capacity{kMaxSlotCapacity};  // grant at most this many slots
  SelectorConfig selector{};
  // Query rate limit (token bucket): a burst of `query_burst`, refilled at
  // `queries_per_s`. A flood beyond it is rejected, not queued.
  double queries_per_s{4.0};
  std::uint32_t query_burst{4};
  // Selection-only batches (pose or query moved, scene did not) are held back while
  // more than this many batches are unacknowledged: a slow link gets one coalesced
  // batch later instead of a queue of stale ones.
  std::uint32_t max_unacked_batches{2};
  // Re-selection under head motion (selection-only batches). A standing user sways a
  // few centimetres and degrees around a pose; re-selecting at each extreme of that
  // sway swaps the selector's marginal Gaussians out and back in (flicker): its
  // retention bonus is relative, and the facing ramp outside the frustum changes the
  // utility of a Gaussian near the ramp's end by far more than 30 % per degree.
  // So the host follows two poses:
  //   - the sway centre: the reported pose low-passed with time constant
  //     `pose_smoothing_s` (0 = follow the raw pose, no sway rejection). When it has
  //     drifted more than `pose_epsilon_m` / `pose_epsilon_rad` (radians of view
  //     direction) from the pose of the last selection, the host re-selects at it.
  //   - the raw pose: a move beyond `pose_jump_m` / `pose_jump_rad` from the pose of the
  //     last selection (walking, a head turn, a teleport) re-selects at once at the raw
  //     pose and restarts the low-pass there, so real motion is never lagged by more
  //     than the jump threshold.
  // A sway whose low-passed amplitude stays below epsilon and whose raw amplitude stays
  // below the jump threshold never re-selects: no churn, no flicker.
  // A head held still for `pose_still_s` (its reported pose within kStillPoseM / kStillPoseRad
  // of where the stillness began) is no sway: the centre goes to it at once. Otherwise the
  // low-pass would creep on for seconds after a stop and re-select late, once per epsilon
  // crossed (at a time constant of 1 s an 11 cm step crosses 5 cm after 0.6 s and 10 cm after
  // 2.4 s), and a client deciding it has settled could leave with a batch in flight. 0: never.
  double pose_still_s{0.5};
  double pose_epsilon_m{0.05};
  double pose_epsilon_rad{0.05};
  double pose_smoothing_s{1.0};
  double pose_jump_m{0.15};
  double pose_jump_rad{0.15};
  // The share of the budget a query reserves for its target when the client leaves it to
  // the host (msg::kHostDefaultRho). In [0, 1].
  double default_rho{0.9};
  // Which Gaussians may be selected at all (opacity, scale, support, surface distance);
  // empty = every Gaussian. Filtered once per scene epoch.
  std::optional<EligibilityConfig> eligibility;
  // With eligibility: the verdict shared with the other sessions (SessionHost shares one; its
  // rule must be `eligibility`). Null: the session filters for itself.
  std::shared_ptr<SharedEligibleSet> shared_eligible;
  // Level of detail (lod_selector.h): when set, what the budget leaves of the background is a
  // cut through a merge hierarchy of the eligible Gaussians instead of its best leaves, so
  // the client shows coarse context where leaf selection leaves holes. The reservation's
  // leaves and shares are unchanged; at M >= N the set is exactly the leaf selection's. The
  // codec's log-scale range must reach the interior records' (fit_lod_codec_params).
  std::optional<LodConfig> lod;
  // With lod: the hierarchy to read, shared with other sessions (one per host instead of one
  // per client: the sessions sharing it must have the same eligibility and SH degree; `lod` is
  // then only a switch, the shared one's config applies). Null: the session builds its own.
  std::shared_ptr<LodEpochHierarchy> shared_lod;
  // With shared_lod: its owner updates it off the serving path
  // (LodEpochHierarchy::update_in_background, between the sessions' ticks), and the session
  // only reads it: a tick while it is not yet at the scene's epoch sends nothing and waits
  // for a later one. Ignored without shared_lod.
  bool lod_in_background{false};
  // The selection's per-Gaussian terms, shared with the other sessions reading the same
  // scene (SessionHost shares one set between all its sessions). Null: the session's own.
  std::shared_ptr<SelectorTerms> shared_selector_terms;
  // How a viewer first looks at the scene (SceneInfo::view; scene_view.h makes one for a
  // file, a folder or a capture). Unset: +y up, standing inside the scene's bounds, the
  // view of a room such as the synthetic scene's.
  std::optional<msg::SceneView> view;
};

struct HostSessionStats {
  std::uint64_t rejected_messages{0};   // everything below, summed
  std::uint64_t rejected_before_hello{0};
  std::uint64_t rejected_duplicate_hello{0};
  std::uint64_t rejected_direction{0};
  std::uint64_t stale_poses{0};
  std::uint64_t rejected_queries{0};    // rate limit (a query matching nothing is answered NoMatch, not counted)
  std::uint64_t batches_sent{0};
  std::uint64_t edits_sent{0};
  std::uint64_t payload_bytes_sent{0};  // codec bytes (compressed)
  std::string last_rejection;
  std::uint64_t lod_fallbacks{0};       // epochs whose hierarchy could not be updated (leaf selection instead)
};

class HostSession {
 public:
  HostSession(std::uint32_t client_id, std::uint64_t session_id, CodecParams params, HostSessionConfig config = {});

  // One decoded message from the client at host time `now` (seconds). Returns the
  // replies to send (Welcome/Refuse, QueryReply). `scene` resolves queries.
  std::vector<wire::Message> on_message(const wire::Message& m, const SceneStore& scene, double now);

  // The host loop's tick, between epochs: when the scene advanced, or the pose/query
  // moved (and the link keeps up), select + diff + encode. Returns the model-stream
  // messages to send, in order: after the Welcome, SceneInfo, every surface chunk the
  // scene holds, then the resync snapshot (the client drops any chunk the resync did
  // not resend when it applies the snapshot); later, one batch per new epoch (possibly
  // empty) plus selection-only batches, each followed by its surface patches and
  // object-table update. Errors name a selector/differ failure; the
  // session stays usable.
  Expected<std::vector<wire::Message>> tick(const SceneStore& scene, double now);

  bool accepted() const noexcept { return accepted_; }
  bool closed() const noexcept { return closed_; }
  std::uint32_t client_id() const noexcept { return client_id_; }
  std::uint32_t capacity() const noexcept { return capacity_; }
  const HostSessionStats& stats() const noexcept { return stats_; }
  // Lines for the host's log that no message carries (a LoD fallback), oldest first; taken
  // once.
  std::vector<std::string> take_notices() { return std::exchange(notices_, {}); }
  // The LoD state, when config.lod is set.
  const LodSelector* lod() const noexcept { return lod_ ? &*lod_ : nullptr; }
  // Stage events (available, sent; query resolved, target, desired residency).
  EventLog& events() noexcept { return events_; }
  // The desired set as last sent (sorted ids) and its checksum over the records the
  // client decodes, to compare with the client's state. Both are what was sent, however the
  // scene or the LoD hierarchy has moved on since.
  const std::vector<GaussianId>& sent_ids() const noexcept { return sent_ids_; }
  std::uint64_t sent_checksum() const;
  // The record a sent id's client holds, as it decodes it (quantised; a scene Gaussian or a
  // LoD cut's interior record); nullopt when the id was not sent.
  std::optional<Gaussian> sent_record(GaussianId id) const { return differ_.sent_record(id); }
  std::optional<msg::Ack> last_ack() const noexcept { return last_ack_; }
  std::uint64_t last_batch_id() const noexcept { return next_batch_id_ - 1; }

 private:
  // Counts a rejection in rejected_messages (and in `counter`, its reason's own count).
  void reject(std::string reason);
  void reject(std::uint64_t& counter, std::string reason);
  msg::SceneInfo scene_info(const SceneStore& scene) const;
  // What the scene's change log says changed in the epochs after the last batch up to
  // `epoch`: one walk for the surface patches and the object-table update.
  struct SceneDelta {
    bool complete{true};                // the log still reaches back to the last batch
    bool objects_changed{false};
    std::vector<std::uint32_t> chunks;  // surface chunks changed (unsorted, may repeat)
  };
  SceneDelta delta_since_sent(const SceneStore& scene, Epoch epoch) const;
  // Surface patches for a batch of `epoch`: every chunk when `all` (a resync, or a
  // log that no longer reaches back), else those in `chunks`.
  std::vector<wire::Message> surface_patches(const SceneStore& scene, Epoch epoch, bool all,
                                             std::vector<std::uint32_t> chunks) const;
  // Why the host should re-select for the client's motion, if at all.
  enum class Motion { None, Drift, Jump };
  Motion pose_motion() const;
  void follow_pose(const msg::HeadPose& pose, double now);

  std::uint32_t client_id_;
  std::uint64_t session_id_;
  CodecParams params_;
  HostSessionConfig config_;
  Selector selector_;
  std::shared_ptr<const EligibleSet> eligible_;  // config_.eligibility's verdict at eligible_->epoch
  Differ differ_;
  std::optional<LodSelector> lod_;
  std::vector<std::string> notices_;
  EventLog events_;
  HostSessionStats stats_;

  bool accepted_{false};
  bool closed_{false};
  bool needs_resync_{false};
  std::uint32_t capacity_{0};
  std::optional<msg::HeadPose> pose_;           // latest reported (raw) pose
  std::optional<msg::HeadPose> centre_;         // low-passed pose: the sway centre
  double centre_time_{0.0};                     // host time of the last low-pass step
  std::optional<msg::HeadPose> still_pose_;     // where the head's current stillness began
  double still_since_{0.0};                     // and when
  std::optional<msg::HeadPose> selected_pose_;  // pose the last selection was made at
  std::optional<SemanticQuery> query_;
  double rho_{0.0};
  bool query_changed_{false};
  std::uint32_t query_id_{0};
  double bucket_{0.0};
  double bucket_time_{0.0};
  std::optional<Epoch> sent_epoch_;   // scene epoch of the last batch
  std::uint64_t next_batch_id_{1};
  std::optional<msg::Ack> last_ack_;
  std::vector<GaussianId> sent_ids_;
  std::set<std::int32_t> sent_objects_;
};

// The coarse pose the selector uses for a wire HeadPose.
ClientPose to_client_pose(const msg::HeadPose& pose);
// The coarse head pose a client reports for a view camera (sequence and time unset).
msg::HeadPose head_pose_from_camera(const Camera& camera);

}  // namespace gauss
