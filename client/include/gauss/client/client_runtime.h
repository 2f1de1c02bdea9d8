#pragma once
// ClientRuntime: the one client, assembled. Every program that receives the stream and
// shows it (gauss-view windowed and headless, the headset program, gauss-eval, tests)
// runs this and adds only its frame loop and its target:
//
//   transport ─ NetClient over ENet (its own thread), or deliver()/take_outgoing() for an
//       │       in-process link (deterministic simulation, tests)
//       ▼
//   ClientState: desired / published state, Publisher under its allowance, epoch barrier
//       ▼  (display thread, once per frame)
//   GpuPublication: merged dirty slot ranges and committed surface chunks → staging ring
//       ▼
//   SplatRenderer: frames_in_flight frames; 1 view (desktop) or 2 (stereo eyes); hooks
//       record the frame's target (a swapchain image, UI) into the same command buffer.
//
// The display thread never waits on the network: the network thread only decodes into
// ClientState (under ClientState's short lock, no I/O held), and frame() takes that lock
// only for the publication step (not at all with the publication thread, below). The
// publication step is the only writer of the slot table and the committed surface, so
// they are read without the lock while no step runs.
//
// Publication thread (ClientRuntimeConfig::publication_thread): publishing and packing
// cost the display thread up to ~1 µs per slot written (scattered reads of the desired
// state and slot table, records packed into the GPU layout), tens of ms in a frame after
// a teleport. With the thread, a display frame takes the step the thread finished
// (queues its packed runs as copies from its pack buffer, clears, tints, surface) and
// asks for the next one, which runs while the frame renders: publication shows one frame
// later, the display thread's share is O(runs) and a step that takes longer than a
// frame spreads over frames instead of stalling one. The display thread never takes
// ClientState's lock then: the head pose, frame-shown notes and frame costs travel with
// the next step. Between take() and the next request the thread is idle, so the display
// thread reads the slot table and the committed surface then without the lock.
//
// Renderer: created at start for SH degree 0; when the stream's SceneInfo announces
// another degree the renderer is recreated for it and every resident slot and chunk is
// uploaded again (a new scene, not a frame-path event).
#include <array>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "gauss/client/gpu_frame_stats.h"
#include "gauss/client/gpu_publication.h"
#include "gauss/client/step_thread.h"
#include "gauss/engine/client_state.h"
#include "gauss/engine/result.h"
#include "gauss/net/client.h"
#include "gauss/net/client_state_sink.h"
#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_staged_uploads.h"

namespace gauss::vk {
class Context;
}

namespace gauss::client {

struct ClientRuntimeConfig {
  ClientConfig state{};                 // M (capacity), publication, token, name
  std::uint32_t frames_in_flight{2};
  std::uint32_t max_width{1280};        // largest view the renderer takes
  std::uint32_t max_height{720};
  render::SplatRenderOptions render{};
  bool highlight_query{true};           // tint the objects of the resolved query
  bool tint_edits{false};               // edit visualisation: tint slots as they change
  double pose_period_s{0.1};            // the coarse head pose goes to the host at ~10 Hz
  // Publication on a thread of its own (see "Publication thread" above): the display
  // thread only hands over and queues copies. Off: each frame publishes and packs on the
  // display thread before it renders (deterministic: tests, simulations, goldens).
  bool publication_thread{false};
  // With publication_thread: lock step. The step asked for in frame k always reaches frame
  // k + 1, and every other entry point that reaches ClientState (deliver, take_outgoing,
  // with_state, resident_per_object, the next frame) first waits for the running step. The
  // step still overlaps the frame's rendering, so the display thread's frame time is what a
  // threaded client pays, while the results are a function of the inputs alone: for
  // simulations that measure the threaded display thread (gauss-eval's stereo timing). A
  // real display must not use it: a step longer than a frame would stall the next frame.
  bool publication_lockstep{false};
  // Slots one publication step packs off the display thread at most (per pack buffer;
  // frames_in_flight + 2 buffers of this many slots); a step writing more leaves the rest
  // to the display thread. 0 = capacity.
  std::uint32_t pack_slots_per_step{65536};
  // Upload copy groups of at least this many regions go to the GPU as one compute scatter
  // (SplatRendererCreateInfo::upload_scatter_min_regions); tests force 0 or UINT32_MAX.
  std::uint32_t upload_scatter_min_regions{vk::kDeviceScatterMinRegions};
  // The client's clock in seconds (arrivals on the network thread and frames share it).
  // Empty: steady time since the runtime was created. A simulation passes virtual time.
  std::function<double()> clock;
};

// One display frame as the CPU saw it (GPU figures arrive later: GpuFrameStats).
struct DisplayFrameStats {
  std::uint64_t frame_index{0};
  std::uint64_t serial{0};          // the renderer's frame serial
  double now{0.0};
  double cpu_ms{0.0};               // the whole frame on the display thread
  double publish_ms{0.0};           // ClientState::frame: policy, slot table (lock_wait_ms included)
  double lock_wait_ms{0.0};         // of which waiting for ClientState's lock (the network thread applying)
  double upload_ms{0.0};            // packing slots and chunks into the staging ring
  // The display thread's CPU time (CLOCK_THREAD_CPUTIME_ID) in publication (lock wait
  // excluded: a thread waiting for the lock uses none) and in the upload packing: what the
  // two stages take from the display core, beside their wall time above.
  double publish_cpu_ms{0.0};
  double upload_cpu_ms{0.0};
  // This frame's upload pass: VkBufferCopy regions recorded, and the regions applied by the
  // compute scatter instead (StagedUploads, many-region groups) with its piece-table entries.
  std::uint32_t copy_regions{0};
  std::uint32_t scatter_regions{0};
  std::uint32_t scatter_pieces{0};
  // Publication thread (ClientRuntimeConfig::publication_thread): whether a step's result
  // reached this frame, and what that step cost the publication thread (ClientState::frame
  // under the lock, and packing its slots), CPU (CLOCK_THREAD_CPUTIME_ID) and wall.
  // Without the thread, the step is this frame's own: publish_* above include it.
  bool publication_threaded{false};
  bool step_taken{false};
  double step_publish_cpu_ms{0.0};
  double step_pack_cpu_ms{0.0};
  double step_publish_ms{0.0};
  double step_pack_ms{0.0};
  double render_ms{0.0};            // recording + submission (includes waiting for frame k - N)
  PublishReport publish;
  PublicationResult uploaded;
  std::uint32_t ranges{0};
  std::optional<Epoch> published_epoch;
  std::optional<Epoch> surface_epoch;
  std::uint32_t resident{0};        // Gaussians in slots
  std::uint64_t desired{0};         // Gaussians the host wants resident
  std::uint32_t pending{0};         // edits received, not yet published
  // As of the publication step this frame took (or the last one): for panels, which must
  // not take the state's lock every frame.
  bool welcomed{false};
  ClientStatsCounters counters{};
};


struct ConnectionInfo {
  bool networked{false};            // false: in-process link
  net::ClientStatus status{net::ClientStatus::Stopped};
  net::ClientCounters counters{};
  std::string server;
};

class ClientRuntime {
 public:
  // Errors: a ClientConfig the ClientState refuses (capacity), a renderer that cannot be
  // created (capacity over the device's binding range, sizes), frames_in_flight.
  static Expected<std::unique_ptr<ClientRuntime>> create(vk::Context& context, ClientRuntimeConfig config);
  ~ClientRuntime();  // stops the network thread, waits for the frames in flight
  ClientRuntime(const ClientRuntime&) = delete;
  ClientRuntime& operator=(const ClientRuntime&) = delete;

  // Starts the network service (it connects and reconnects in the background; the
  // Hello carries this runtime's capacity, token and name). Errors: already connected,
  // the service could not start.
  Status connect(net::NetClientConfig net);
  // In-process link: a host message for this client (Welcome and Refuse included), and
  // the client->host messages queued since the last call.
  void deliver(const wire::Message& message);
  std::vector<wire::Message> take_outgoing();

  // One display frame: publication, uploads, 1 or 2 views rendered into the renderer's
  // targets (view v -> target(v)) plus what `hooks` add, at the clock's now(). Errors: a
  // renderer or publication failure (named); the state stays consistent and the next
  // frame retries.
  Expected<DisplayFrameStats> frame(std::span<const Camera> views, const render::FrameHooks& hooks = {});
  double now() const { return config_.clock(); }
  // GPU statistics of the frames that finished since the last call, oldest first.
  std::vector<GpuFrameStats> take_gpu_stats();
  // Waits for every frame in flight (before readbacks or shutdown; not per frame).
  Status wait_frames();

  // --- intent ---
  // Sends a query (queued until connected; resent after a reconnect). Returns its id.
  // With the publication thread these never wait for a running step: the id is reserved
  // now and the query, mode or period goes to ClientState with the next step (at most a
  // frame later), in the order of the calls. Call them from the thread that calls frame().
  std::uint32_t send_query(msg::Query query);
  void clear_query();
  void set_publish_mode(PublishMode mode);
  // The display period progressive publication keeps frames within (the display's rate).
  void set_display_period(double seconds);
  PublishMode publish_mode() const noexcept { return mode_; }
  void set_highlight(bool on) noexcept { config_.highlight_query = on; }
  void set_tint_edits(bool on) noexcept { config_.tint_edits = on; }
  render::SplatRenderOptions& render_options() noexcept { return config_.render; }

  // --- inspection ---
  // Runs f(const ClientState&) with the network thread kept out (and the publication
  // thread: waits while a step runs).
  template <class F>
  decltype(auto) with_state(F&& f) {
    join_lockstep_step();
    return sink_->with_state([&](ClientState& s) -> decltype(auto) { return f(static_cast<const ClientState&>(s)); });
  }
  // The same if the state is free now, else nothing: for a display loop's inspection (a
  // panel skips a refresh rather than wait for a publication step).
  template <class F>
  auto try_with_state(F&& f) {
    join_lockstep_step();
    return sink_->try_with_state([&](ClientState& s) { return f(static_cast<const ClientState&>(s)); });
  }
  // Resident Gaussians per object id (O(M): for panels and reports, not per frame).
  std::map<std::int32_t, std::uint32_t> resident_per_object();
  static std::map<std::int32_t, std::uint32_t> resident_per_object(const ClientState& state);
  ConnectionInfo connection() const;
  render::SplatRenderer& renderer() noexcept { return *renderer_; }
  const GpuPublication& publication() const noexcept { return publication_; }
  std::uint32_t capacity() const noexcept { return config_.state.capacity; }
  std::uint64_t frames_rendered() const noexcept { return frame_index_; }
  const ClientRuntimeConfig& config() const noexcept { return config_; }

 private:
  ClientRuntime(vk::Context& context, ClientRuntimeConfig config, std::unique_ptr<ClientState> state);
  Status make_renderer(int sh_degree);

  // One publication step: ClientState::frame and the packing of its slot uploads.
  struct RenderedNote {
    double now;
    std::uint64_t frame_index;
    std::uint64_t shown_step;
  };
  struct PublicationJob {
    ViewState view;
    double now{0.0};
    std::uint64_t frame_index{0};
    bool highlight_query{true};
    std::optional<msg::HeadPose> pose;
    std::vector<RenderedNote> rendered;  // applied before the step (publication thread)
    std::vector<double> frame_costs;
    // Intent from the display thread, applied before the step in this order.
    std::vector<msg::Query> queries;  // ids reserved (ClientState::reserve_query_id)
    std::optional<PublishMode> mode;
    std::optional<double> display_period;
    int pack_buffer{-1};                 // pack_pool_ index, or none: nothing packed
    std::span<std::byte> pack;
    render::SlotLayout layout;
  };
  struct PreparedStep {
    std::string error;
    FrameResult result;
    std::optional<int> sh_degree;
    std::vector<ObjectId> targets;
    std::uint64_t desired{0};
    std::uint32_t pending{0};
    std::uint32_t resident{0};
    bool welcomed{false};
    ClientStatsCounters counters{};
    PreparedSlots slots;
    PreparedSurface surface;  // prepared under the state lock
    int pack_buffer{-1};
    double lock_wait_ms{0.0}, publish_ms{0.0}, publish_cpu_ms{0.0}, pack_ms{0.0}, pack_cpu_ms{0.0};
  };
  PreparedStep prepare_step(PublicationJob& job);
  // publication_lockstep: waits until no step runs (else returns at once).
  void join_lockstep_step();
  // Display thread, with the publication thread idle.
  Status apply_step(PreparedStep& step, DisplayFrameStats& out);
  int free_pack_buffer();

  struct PackBuffer {
    vk::Buffer buffer;
    std::uint64_t serial{0};  // the frame that copies from it (0: none yet)
    bool taken{false};        // with a step, or queued and not yet submitted
    std::span<std::byte> bytes() const { return {static_cast<std::byte*>(buffer.mapped()), buffer.size()}; }
  };
  PackBuffer& pack_buffer(int index) { return pack_pool_[static_cast<std::size_t>(index)]; }
  std::vector<PackBuffer> pack_pool_;
  std::vector<int> unsubmitted_;        // pack buffers whose copies wait for a submission
  PublicationJob next_job_;             // notes gathered for the next request
  std::uint64_t shown_step_{0};
  std::chrono::steady_clock::time_point requested_at_{};  // of the step the thread runs
  std::uint64_t last_desired_{0};
  std::uint32_t last_pending_{0}, last_resident_{0};
  bool last_welcomed_{false};
  ClientStatsCounters last_counters_{};
  std::unique_ptr<StepThread<PublicationJob, PreparedStep>> worker_;  // last: stops first

  vk::Context* context_;
  ClientRuntimeConfig config_;
  std::unique_ptr<ClientState> state_;
  std::unique_ptr<net::ClientStateSink> sink_;
  std::unique_ptr<net::NetClient> net_;
  std::string server_;
  std::unique_ptr<render::SplatRenderer> renderer_;
  GpuPublication publication_;
  PublishMode mode_{PublishMode::Progressive};
  std::vector<ObjectId> highlighted_;
  double last_pose_time_{-1e300};
  std::uint64_t frame_index_{0};
  GpuFrameStatsCollector gpu_stats_;
};

}  // namespace gauss::client
