// Frame timing while publication runs: the headset's case. Stereo (two eyes per frame,
// --ipd apart), M = --stereo-budget, progressive publication, on this machine's Vulkan
// device. Publication runs on the client's own thread, as a headset's client runs it, in
// lock step (ClientRuntimeConfig::publication_lockstep): the display thread's time per
// frame is the threaded client's (the step overlaps the frame's rendering), and the
// deterministic part stays deterministic.
//
// On a fresh connection: settle at A (fidelity camera 0) and render kTimingIdleFrames more
// frames there (idle before); teleport to B (temporal.cpp's target) and keep every frame
// until the client has converged (streaming: the frames while the edits of a far
// teleport are published); then kTimingIdleFrames at B (idle after, the same resident count as
// the streaming frames end with); then "sustained": kSustainedFrames more display frames at
// B back to back, without the simulated host's ticks between them, of which the last half
// count. In the paced phases the GPU idles while this process simulates the host, and a GPU
// that idles lowers its clocks (an H100 ran them at 345-450 MHz SM against 1980 in
// gauss-bench's back-to-back frames: nvidia-smi through scripts/gpu-ab), so their GPU ms
// measure the clock as much as the renderer; the sustained frames render the same set and
// eyes with the GPU kept busy. Per phase the display thread's CPU ms per frame and the
// GPU ms per pass (both eyes summed) are percentiles of the wall clock, so they live in
// report.json's "timing"; the deterministic part (frames, virtual convergence time, slot
// writes, resident) is the section's own.
#include <chrono>

#include "gauss/render/splat_math.h"
#include "measurements.h"

namespace gauss::eval_app {

namespace {

constexpr int kTimingIdleFrames = 24;
constexpr int kSustainedFrames = 240;

struct Phase {
  explicit Phase(const char* n, bool is_paced = true) : name(n), paced(is_paced) {}
  const char* name;
  bool paced;  // frames at the display's pace, the host ticking between them
  std::uint64_t first{0}, last{0};  // display frame indices, inclusive
  std::vector<double> cpu_ms;
  Timing gpu;
  // What the GPU passes worked on, per frame: the slots' high-water mark (preprocess and
  // compact run over it), and each eye's visible splats (the depth sort's keys) and pairs.
  std::vector<double> high_water, visible, pairs;
};

}  // namespace

Expected<Json> measure_stereo_timing(Room& room, Json& timing) {
  const auto t0 = std::chrono::steady_clock::now();
  const Options& o = room.options;
  const EvalScene& scene = room.scene;
  auto stream = open_stream(room, o.stereo_budget, PublishMode::Progressive, /*publication_thread=*/true);
  if (!stream) return stream.error();
  EvalSession& session = *stream->session;
  const Camera a = scene.cameras.front();
  const Camera b = teleport_target(a, scene);
  auto eyes = [&](const Camera& c) {
    return std::array<Camera, 2>{render::stereo_eye_camera(c, o.ipd, render::Eye::Left),
                                 render::stereo_eye_camera(c, o.ipd, render::Eye::Right)};
  };
  const auto eyes_a = eyes(a), eyes_b = eyes(b);

  room.progress("stereo timing: settling at A (M = " + std::to_string(o.stereo_budget) + ")");
  auto first = session.settle_views(eyes_a, o.settle_timeout_s, o.quiet_s);
  if (!first) return first.error();
  Phase phases[4] = {Phase("idle_before"), Phase("streaming"), Phase("idle_after"), Phase("sustained", /*is_paced=*/false)};
  auto idle = [&](Phase& p, std::span<const Camera> views) -> Status {
    for (int k = 0; k < kTimingIdleFrames; ++k) {
      auto f = session.step_views(views);
      if (!f) return f.error();
      if (k == 0) p.first = f->frame_index;
      p.last = f->frame_index;
      p.cpu_ms.push_back(f->cpu_ms);
    }
    return Ok{};
  };
  if (auto st = idle(phases[0], eyes_a); !st) return st.error();
  const std::uint32_t resident_a = session.client().with_state([](const ClientState& s) {
    return s.slots().size();
  });

  room.progress("stereo timing: teleport to B, publishing");
  Phase& streaming = phases[1];
  bool first_frame = true;
  auto away = session.settle_views(eyes_b, o.settle_timeout_s, o.quiet_s, [&](const client::DisplayFrameStats& f) {
    if (first_frame) streaming.first = f.frame_index;
    first_frame = false;
    streaming.last = f.frame_index;
    streaming.cpu_ms.push_back(f.cpu_ms);
  });
  if (!away) return away.error();
  room.progress("stereo timing: idle at B");
  if (auto st = idle(phases[2], eyes_b); !st) return st.error();
  // A wall-clock figure only (left out with --no-timing, as every other).
  if (o.timing) room.progress("stereo timing: sustained frames at B");
  for (int k = 0; o.timing && k < kSustainedFrames; ++k) {
    auto f = session.client().frame(eyes_b);
    if (!f) return Error{"stereo timing: sustained frame: " + f.message()};
    if (k < kSustainedFrames / 2) continue;  // the clocks ramp up meanwhile
    if (phases[3].cpu_ms.empty()) phases[3].first = f->frame_index;
    phases[3].last = f->frame_index;
    phases[3].cpu_ms.push_back(f->cpu_ms);
  }
  // The last frames' GPU work finishes before their statistics are read.
  if (auto img = session.client().renderer().read_image(); !img) return img.error();
  for (const client::GpuFrameStats& g : session.client().take_gpu_stats())
    for (Phase& p : phases)
      if (!p.cpu_ms.empty() && g.frame_index >= p.first && g.frame_index <= p.last) {  // empty: not run
        p.gpu.add_gpu({g});
        p.high_water.push_back(g.view[0].high_water);
        for (std::uint32_t v = 0; v < g.views && v < g.view.size(); ++v) {
          p.visible.push_back(g.view[v].visible);
          p.pairs.push_back(g.view[v].pairs);
        }
      }
  const std::uint32_t resident_b = session.client().with_state([](const ClientState& s) {
    return s.slots().size();
  });

  Json phase_timing = Json::object();
  for (Phase& p : phases) {
    Json passes = Json::object();
    for (const auto& [pass, ms] : p.gpu.pass_gpu_ms) passes[pass] = percentiles(ms);
    phase_timing[p.name] = Json{{"frame_cpu_ms", percentiles(p.cpu_ms)},
                                {"frame_gpu_ms", percentiles(p.gpu.frame_gpu_ms)},
                                {"pass_gpu_ms", std::move(passes)},
                                {"high_water", percentiles(p.high_water)},
                                {"visible_per_eye", percentiles(p.visible)},
                                {"pairs_per_eye", percentiles(p.pairs)}};
    if (p.paced)  // the run's display-thread summary counts paced frames only
      room.timing.frame_cpu_ms.insert(room.timing.frame_cpu_ms.end(), p.cpu_ms.begin(), p.cpu_ms.end());
  }
  timing = Json{{"budget", o.stereo_budget},
                {"views", 2},
                {"width", o.width},
                {"height", o.height},
                {"wall_s", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()},
                {"phases", std::move(phase_timing)}};
  return Json{{"budget", o.stereo_budget},
              {"ipd_m", o.ipd},
              {"views", 2},
              {"width", o.width},
              {"height", o.height},
              {"allowance", o.allowance},
              {"a", camera_json(a)},
              {"b", camera_json(b)},
              {"resident_at_a", resident_a},
              {"resident_at_b", resident_b},
              {"idle_frames", kTimingIdleFrames},
              {"settle_a", settle_json(*first)},
              {"teleport", settle_json(*away)},
              {"stream", stream_json(session)}};
}

}  // namespace gauss::eval_app
