#pragma once
// EvalSession: one host and one client in this process, on a virtual clock, joined by a
// modelled link: what gauss-eval measures.
//
//   SceneStore ── HostSession (the host's side of the connection: selection, diff, codec)
//        │            │ encoded wire bytes ─ sim::Link down (latency, bandwidth, ordered)
//        │            ▼
//        │       ClientRuntime.deliver() → ClientState → GPU publication → SplatRenderer
//        │            │ take_outgoing(): acks, poses, queries ─ sim::Link up
//        └────────────┘
//
// Determinism: the client's clock is the session's virtual time (frame k is displayed at
// k / display_hz), the host ticks every host_tick_s of that time, messages cross the links
// as their real encoded bytes and arrive at times the seeded link model computes, and the
// progressive allowance is fixed (allowance_min = max), so the frame cost the client
// measures on the wall clock never steers publication. The renders are real (lavapipe is
// deterministic), so every figure but the wall-clock ones reproduces bit for bit.
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "gauss/client/client_runtime.h"
#include "gauss/engine/codec.h"
#include "gauss/engine/host_session.h"
#include "gauss/engine/result.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/sim_link.h"

namespace gauss::vk {
class Context;
}

namespace gauss::eval_app {

struct EvalSessionConfig {
  std::uint32_t budget{5000};  // M
  std::uint32_t width{160}, height{120};
  PublishMode mode{PublishMode::Progressive};
  std::uint32_t allowance{2000};  // progressive: slot edits per frame, fixed
  double display_hz{72.0};
  double host_tick_s{0.02};       // the host loop's period
  sim::LinkConditions down{}, up{};
  std::uint64_t seed{1};          // link model seed
  double default_rho{0.9};        // the host's rho when a query leaves it to the host
  // Publication on the client's own thread in lock step (ClientRuntimeConfig::
  // publication_lockstep): the display thread's frame time is a threaded client's, and the
  // run stays deterministic; a step shows one frame later than inline.
  bool publication_thread{false};
  // The host's level of detail (HostSessionConfig::lod): a coarse cut for the background.
  // The codec must reach the interior records (fit_lod_codec_params).
  bool lod{false};
};

// One settled view (settle()).
struct SettleResult {
  bool converged{false};
  double start_s{0.0};        // virtual time settle() began
  double in_sync_s{-1.0};     // seconds to the first frame with published == desired == sent (-1: never)
  double converged_s{-1.0};   // seconds to the first frame of the final in-sync run (-1: never)
  std::uint64_t frames{0};    // display frames rendered
  std::uint64_t slot_writes{0};
  std::vector<double> frame_cpu_ms;  // wall clock: the display thread's time per frame
};

class EvalSession {
 public:
  // Errors: a ClientRuntime that cannot be created (capacity, sizes), a refused Hello.
  static Expected<std::unique_ptr<EvalSession>> create(vk::Context& context, const SceneStore& scene,
                                                       const CodecParams& params, const EvalSessionConfig& config);

  // One display frame at `view`: host ticks due by now, messages due by now delivered,
  // the client's frame rendered, its outgoing messages sent; then time advances by one
  // display period. Errors: a host tick, a message that does not encode or decode, the
  // client's frame.
  Expected<client::DisplayFrameStats> step(const Camera& view);
  // The same with 1 or 2 views (view 0 is the head: its pose goes to the host).
  Expected<client::DisplayFrameStats> step_views(std::span<const Camera> views);
  // Frames at `view` until the client has been in sync (nothing in flight to it, nothing
  // pending, its published set = the host's sent set, checksum over the decoded records)
  // for `quiet_s` without a new host message, or `timeout_s` passed. `on_frame` (may be
  // empty) sees every frame.
  Expected<SettleResult> settle(const Camera& view, double timeout_s, double quiet_s,
                                const std::function<void(const client::DisplayFrameStats&)>& on_frame = {});
  // The same with 1 or 2 views per frame (stereo: view 0 is the head).
  Expected<SettleResult> settle_views(std::span<const Camera> views, double timeout_s, double quiet_s,
                                      const std::function<void(const client::DisplayFrameStats&)>& on_frame = {});
  // In sync now: welcomed, nothing in flight to the client, nothing pending, published
  // checksum == the host's sent checksum. O(M).
  bool in_sync();
  // Runs the host's ticks due by virtual time `t` now (step() does so lazily, at the next
  // frame): a scene change made after this call is first seen by a tick after `t`.
  Status run_host_until(double t) { return host_until(t); }

  double now() const noexcept { return now_; }
  client::ClientRuntime& client() noexcept { return *client_; }
  const HostSession& host() const noexcept { return host_; }
  EventLog& host_events() noexcept { return host_.events(); }
  const SceneStore& scene() const noexcept { return *scene_; }
  const CodecParams& codec() const noexcept { return params_; }
  // Host messages sent so far (bytes: wire frames).
  std::uint64_t messages_down() const noexcept { return messages_down_; }
  std::uint64_t bytes_down() const noexcept { return bytes_down_; }

  // Resident Gaussians on any of `targets` (sorted), counted over the client's slots.
  std::uint64_t resident_on(std::span<const ObjectId> targets);
  // The client's slot -> Gaussian id map (kNoGaussian-free: only occupied slots), sorted by slot.
  std::vector<std::pair<std::uint32_t, GaussianId>> slot_ids();
  // Loads the host's own records of the set it sent (each Gaussian as the client decodes
  // it: quantize_roundtrip with the session's codec) into `renderer`, each at the slot the
  // client keeps it in, every other slot cleared, and the scene's surface chunks. Errors:
  // the client holds an id the host did not send or the scene no longer has, a renderer
  // smaller than M, a renderer failure.
  Status load_sent_set(render::SplatRenderer& renderer);

 private:
  EvalSession(const SceneStore& scene, const CodecParams& params, const EvalSessionConfig& config);
  struct InFlight {
    double at{0.0};
    std::vector<std::uint8_t> bytes;
  };
  Status send(std::deque<InFlight>& queue, sim::Link& link, const wire::Message& m, double t);
  Status host_until(double t);
  Status deliver_until(double t);

  const SceneStore* scene_;
  CodecParams params_;
  EvalSessionConfig config_;
  HostSession host_;
  std::unique_ptr<client::ClientRuntime> client_;
  sim::Link down_, up_;
  std::deque<InFlight> to_client_, to_host_;
  double now_{0.0};
  std::uint64_t frame_count_{0};
  double next_tick_{0.0};
  std::uint64_t messages_down_{0}, bytes_down_{0};
  // The host's sent checksum (O(M): it re-quantises the sent set) as of messages_down_.
  std::uint64_t sent_checksum_{0};
  std::uint64_t sent_checksum_at_{~0ull};
};

}  // namespace gauss::eval_app
