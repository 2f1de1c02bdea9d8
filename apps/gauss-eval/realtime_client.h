#pragma once
// The client of gauss-eval --realtime: the real ClientRuntime with its NetClient over
// loopback ENet to a gauss-host process, on the real clock (steady time), with the real
// client's adaptive publication allowance. Nothing here is deterministic: the host runs
// in another process, the network thread delivers when packets arrive, and the allowance
// follows the frame cost measured on the wall clock.
//
// Frames are paced at the display rate (frame k at k / display_hz wall seconds after the
// settle began; a late frame is not made up): a display is paced by its vsync, and an
// unpaced loop would take the cores the host process needs on a small machine.
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "gauss/client/client_runtime.h"
#include "gauss/engine/camera.h"
#include "gauss/engine/image_io.h"
#include "gauss/engine/result.h"

namespace gauss::vk {
class Context;
}

namespace gauss::eval_app {

struct RealtimeClientConfig {
  std::uint16_t port{0};       // gauss-host on 127.0.0.1
  std::string name;            // the Hello's name: the host's dump file is named after it
  std::uint32_t budget{5000};  // M
  PublishMode mode{PublishMode::Progressive};
  double display_hz{72.0};
  std::uint32_t width{160}, height{120};
  bool publication_thread{true};  // as a headset's client runs (ClientRuntimeConfig)
};

// One settled view, on the wall clock.
struct RealtimeSettle {
  bool converged{false};
  double converged_s{-1.0};  // wall seconds from the start to the first frame of the final quiet run (-1: never)
  double wall_s{0.0};        // how long the settle ran
  std::uint64_t frames{0};
  std::uint64_t slot_writes{0};
  std::vector<double> frame_cpu_ms;  // the display thread per frame
};

// A flicker window at a settled view, on the wall clock: the head sways (the first view,
// swayed()) while the settled view is rendered as a second one and compared frame to frame.
struct RealtimeFlicker {
  double window_s{0.0};
  std::uint64_t frames{0};
  double mean_abs_change{0.0}, max_abs_change{0.0};  // per pixel and channel, 8-bit levels
  std::uint64_t slot_writes{0};
  std::uint64_t membership_changes{0};  // inserts + removes + 2 x replaces published
  std::uint64_t host_messages{0};       // received during the window
  std::vector<double> frame_cpu_ms;
};

// A query's stages as the client logged them, wall seconds after it was sent (nullopt: the
// stage was not reached): the host's resolution arrived (targets known), the first frame
// rendered knowing them (the highlight; not tinted here), the first frame with more target
// Gaussians resident than when the query took effect, every desired target Gaussian published.
struct RealtimeQueryStages {
  std::optional<double> targets_s, highlight_s, first_additional_s, converged_s;
  std::optional<std::uint64_t> initial_residency;  // target Gaussians resident when it took effect
};

// The client's state once settled: its frame and the set it published, in slot order.
struct RealtimeCapture {
  ImageRGBA8 hs;
  std::vector<std::pair<std::uint32_t, GaussianId>> slots;  // occupied slots, by slot
  std::vector<ObjectId> slot_objects;                       // the object of each of `slots`' records
  std::uint64_t published_checksum{0};                      // ClientState::published_checksum()
  std::uint32_t resident{0};
  std::uint64_t desired{0};
  std::uint64_t query_target_gaussians{0};  // |G_obj| as the host reported it (0: no query)
};

class RealtimeClient {
 public:
  // Creates the runtime and starts connecting (in the background). Errors: the runtime
  // (capacity, sizes), the network service.
  static Expected<std::unique_ptr<RealtimeClient>> connect(vk::Context& context, const RealtimeClientConfig& config);

  // Frames at `view` until the client was welcomed, had nothing pending, published
  // nothing and received no host message for `quiet_s` wall seconds, or `timeout_s`
  // passed (then converged = false). Errors: a frame failed, the host refused the client.
  Expected<RealtimeSettle> settle(const Camera& view, double timeout_s, double quiet_s);
  // Paced stereo frames for `window_s` wall seconds: view 0 sways around `a`, view 1 is `a`,
  // read back every frame (so these frames wait for the GPU). Errors: a frame, a readback.
  Expected<RealtimeFlicker> flicker(const Camera& a, double window_s);
  // Sends a query (queued until the client is welcomed): its id and the client clock then.
  std::pair<std::uint32_t, double> send_query(const msg::Query& query);
  // Query `id`'s stages from the client's event log, relative to `sent_at` (its clock).
  RealtimeQueryStages query_stages(std::uint32_t id, double sent_at);
  // Frames at `view` until the host's resolution of the query reached the client, so a
  // settle afterwards cannot converge before the host saw the query. Errors: a frame, no
  // resolution within `timeout_s` wall seconds.
  Status wait_for_query(const Camera& view, double timeout_s);
  // The last frame (after the frames in flight finished) and the published set.
  Expected<RealtimeCapture> capture();
  // GPU figures of the frames finished since the last call.
  std::vector<client::GpuFrameStats> take_gpu_stats() { return runtime_->take_gpu_stats(); }
  // Leaves politely (ENet disconnect: the host ends the session and writes its dump) and
  // frees the runtime; the client is unusable afterwards.
  void close() { runtime_.reset(); }

 private:
  RealtimeClient(std::unique_ptr<client::ClientRuntime> runtime, double display_hz)
      : runtime_(std::move(runtime)), display_hz_(display_hz) {}
  // One frame of `views` (1 or 2) at the display rate: sleeps until `next`, then advances it.
  Expected<client::DisplayFrameStats> paced_frame(std::span<const Camera> views,
                                                  std::chrono::steady_clock::time_point& next);

  std::unique_ptr<client::ClientRuntime> runtime_;
  double display_hz_;
};

}  // namespace gauss::eval_app
