#pragma once
// ClientState: the client's side of the stream, transport-agnostic. The network
// service (its own thread, outside the display loop) feeds decoded host messages to
// on_message(), which only updates CPU-side desired state and queues. The display loop
// calls frame() once per display frame: the Publisher moves pending edits into the
// SlotTable under its allowance, the SurfaceStage commits what the epoch barrier
// allows, and the merged dirty slot ranges come back for the renderer's
// write_slots(first_slot, span<const Gaussian>) uploads. No GPU code here.
//
// Thread safety: on_message(), frame(), frame_rendered(), take_outgoing() and the
// query/pose helpers may be called from different threads (one mutex). Accessors
// that return references are for the owning thread between calls (tests, the sim).
//
// Bad input: a batch before SceneInfo, a payload that does not decode, an edit count
// or epoch that disagrees with its header, a batch going back in epoch, a malformed
// surface patch: rejected with a reason and a counter; state untouched; the stream
// continues (a transport may choose to reconnect, which resynchronises).
#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "gauss/engine/desired_state.h"
#include "gauss/engine/messages.h"
#include "gauss/engine/publisher.h"
#include "gauss/engine/slot_table.h"
#include "gauss/engine/stage_events.h"
#include "gauss/engine/surface_stage.h"
#include "gauss/engine/wire.h"

namespace gauss {

struct ClientConfig {
  std::uint32_t capacity{200000};  // M: stable slots, fixed for the client's life
  PublisherConfig publisher{};
  std::string access_token;
  std::string name{"client"};
  // Dirty ranges separated by at most this many clean slots are uploaded as one
  // (re-sending a few clean records beats another copy command).
  std::uint32_t range_merge_gap{0};
  // Arrivals the desired state lists beyond 2M between frames before it drops the lists
  // and the publisher rescans (DesiredState::kArrivalSlack; the fault simulation lowers it
  // so that stalls reach the rescan).
  std::uint32_t arrival_slack{DesiredState::kArrivalSlack};
};

struct ClientStatsCounters {
  std::uint64_t rejected_messages{0};
  std::uint64_t batches{0};
  std::uint64_t edits_received{0};
  std::uint64_t resyncs{0};
  std::string last_rejection;
};

struct FrameResult {
  PublishReport publish;
  std::vector<SlotRange> ranges;     // upload these slot ranges before rendering
  std::uint32_t surface_committed{0};
  std::optional<Epoch> published_epoch;
  std::optional<Epoch> surface_epoch;
  std::uint64_t step{0};             // this frame() call's number, from 1
};

class ClientState {
 public:
  // Fails for a capacity the SlotTable refuses (0 or above kMaxSlotCapacity).
  static Expected<ClientState> create(std::uint32_t client_index, ClientConfig config);

  msg::Hello hello() const;
  // A decoded host message at client time `now`. Error = rejected (counted, state untouched).
  Status on_message(const wire::Message& m, double now);
  // One display frame: publish, commit surface, take the merged dirty ranges.
  Expected<FrameResult> frame(const ViewState& view, double now, std::uint64_t frame_index);
  // The frame that frame() prepared was displayed: first-frame and highlight events.
  // `shown_step`: the newest FrameResult::step whose slots that frame shows (a client
  // that publishes ahead of its display, on another thread, passes the one it uploaded;
  // a batch published by a later step is not on screen yet).
  void frame_rendered(double now, std::uint64_t frame_index, std::uint64_t shown_step = ~std::uint64_t{0});
  // Cost of the last displayed frame (render + publication) for the adaptive allowance.
  void report_frame_cost(double seconds);
  void set_publish_mode(PublishMode mode);
  void set_display_period(double seconds);

  // Control messages to send: acks, poses and queries queued since the last call.
  std::vector<wire::Message> take_outgoing();
  void send_pose(msg::HeadPose pose);              // sequence assigned here
  std::uint32_t send_query(msg::Query query);      // query_id assigned here, returned
  // A query id taken now without the mutex (atomic), for a caller that must not wait for a
  // publication step holding it: send_reserved_query(q) with that id sends it later, in
  // the order of the calls.
  std::uint32_t reserve_query_id() noexcept;
  void send_reserved_query(msg::Query query);      // query.query_id from reserve_query_id()
  // The connection dropped: keep everything (the next Welcome's resync reconciles);
  // resend the current query and pose after the next Welcome. A Welcome from another
  // host session (the host restarted) also restarts the epoch order: the new session's
  // epochs count from its own start (DesiredState / SurfaceStage::restart_epochs).
  void on_disconnect();

  // --- inspection (owning thread) ---
  const DesiredState& desired() const noexcept { return desired_; }
  const SlotTable& slots() const noexcept { return slots_; }
  const SurfaceStage& surface() const noexcept { return surface_; }
  const Publisher& publisher() const noexcept { return publisher_; }
  EventLog& events() noexcept { return events_; }
  const EventLog& events() const noexcept { return events_; }
  const ClientStatsCounters& stats() const noexcept { return stats_; }
  bool welcomed() const noexcept { return welcomed_; }
  std::uint64_t last_batch_id() const noexcept { return last_batch_id_; }
  const std::map<std::int32_t, msg::ObjectInfo>& objects() const noexcept { return objects_; }
  // The stream's codec parameters (SH degree, box) once a SceneInfo arrived.
  const std::optional<CodecParams>& codec() const noexcept { return codec_; }
  // How the host says to look at its scene first (SceneInfo::view); set with the codec.
  const std::optional<msg::SceneView>& view() const noexcept { return view_; }
  // Objects the current resolved query targets (sorted; empty without one): what the
  // renderer highlights.
  std::vector<ObjectId> query_targets() const {
    return query_track_ ? query_track_->targets : std::vector<ObjectId>{};
  }
  // Gaussians the targets held on the host when it resolved the query (0 without one).
  std::uint64_t query_target_gaussians() const { return query_track_ ? query_track_->target_gaussians : 0; }
  // Published slots whose Gaussian belongs to one of `targets` (sorted). O(M).
  std::uint64_t count_resident(std::span<const ObjectId> targets) const;
  // Order-independent checksum of the published (id, record) pairs.
  std::uint64_t published_checksum() const;
  // Every invariant: slot table bijection, desired-state consistency, published total
  // <= M, published count agreeing between the two, the epoch barrier.
  Status check() const;

 private:
  ClientState(std::uint32_t client_index, ClientConfig config, SlotTable slots);
  Status reject(std::string reason);
  struct DecodedBatch {
    CodecParams codec;  // the parameters it was decoded with
    Expected<EditBatch> batch;
  };
  Status on_batch(const msg::EditBatchMsg& b, std::optional<DecodedBatch>& decoded, double now);
  // `slots_written`: this frame's publication wrote slots (target residency may differ).
  void track_query(double now, std::uint64_t frame_index, bool rendered, bool slots_written,
                   std::uint64_t shown_step = ~std::uint64_t{0});

  std::uint32_t client_index_;
  ClientConfig config_;
  std::unique_ptr<std::mutex> mutex_;
  DesiredState desired_;
  SlotTable slots_;
  SurfaceStage surface_;
  Publisher publisher_;
  EventLog events_;
  ClientStatsCounters stats_;

  bool welcomed_{false};
  std::optional<std::uint64_t> host_session_;  // of the last Welcome: another one = the host restarted
  std::optional<CodecParams> codec_;
  std::optional<msg::SceneView> view_;
  std::uint64_t last_batch_id_{0};
  std::map<std::int32_t, msg::ObjectInfo> objects_;
  std::vector<wire::Message> outgoing_;
  std::uint32_t next_pose_seq_{1};
  // Atomic (reserve_query_id() runs outside the mutex); behind a pointer so the state moves.
  std::unique_ptr<std::atomic<std::uint32_t>> next_query_id_;
  std::optional<msg::HeadPose> last_pose_;
  std::optional<msg::Query> last_query_;
  std::optional<Epoch> acked_published_;

  struct PendingBatch {
    std::uint64_t batch_id;
    Epoch epoch;
    std::uint64_t edits;
    bool published{false};
    std::uint64_t published_step{0};  // frame() call that published it
  };
  std::uint64_t step_{0};  // frame() calls so far
  std::vector<PendingBatch> unpublished_;  // received, not yet shown in a rendered frame

  struct QueryTrack {
    std::uint32_t query_id{0};
    std::vector<ObjectId> targets;  // sorted
    std::uint64_t target_gaussians{0};  // on the host, at resolution
    std::uint64_t initial{0};               // target members published when the reply arrived
    bool initial_reported{false};
    std::optional<std::uint64_t> resident;  // target members published, as of the last scan
    bool highlight_shown{false};
    std::uint64_t first_step{0};    // the first frame() after the reply: its targets tint frames showing it
    bool first_additional{false};
    bool converged{false};
    std::uint64_t batch_after{0};   // first batch id sent after the resolution
  };
  std::optional<QueryTrack> query_track_;
};

}  // namespace gauss
