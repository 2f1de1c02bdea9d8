// gauss-bench client: the display frame of the real client path (ClientRuntime: ENet over
// loopback -> ClientState -> staging ring -> SplatRenderer, frames in flight) on this
// machine's Vulkan device.
//   1. far teleport at M of an N-Gaussian synthetic room served by an in-process
//      SessionHost over loopback ENet, per publication mode, repeated (A -> B -> A ...,
//      --teleports): display-frame interval percentiles over the pooled streaming frames,
//      beside the idle interval at the same resident count after each; convergence time
//      (teleport -> first frame from which nothing is pending and the host sent nothing
//      more); the network thread's CPU time per teleport (what it takes from the client's
//      core). Publication runs on the client's publication thread unless
//      --publication-thread off: the display thread's publish / upload CPU is then the
//      handover, and the step's own CPU (ClientState::frame, packing) is reported apart.
//   2. frame cost calibration: blocking frames (CPU packing + GPU copies + passes) while
//      K slots are rewritten in R runs, fitted by least squares as base + a K + b R: the
//      simulation's FrameCostModel from this device, beside its old constants, with the
//      fit's RMS residual.
//   3. upload throughput: the staging ring (pack straight into the ring, copies recorded
//      into a frame) against a per-call staging buffer (the old Buffer::upload path of a
//      device without host-visible memory), GiB/s, for 1 and for many ranges.
// Timing never decides a test. Lavapipe renders on the CPU, so its absolute figures say
// little about a headset; the ratios within one run are the result.
#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <optional>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench_registry.h"
#include "bench_util.h"
#include "gauss/client/client_runtime.h"
#include "gauss/engine/host_session.h"
#include "gauss/engine/synthetic_scene.h"
#include "gauss/net/session_host.h"
#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_frame_ring.h"
#include "gauss/render/vk_staged_uploads.h"
#include "gauss_cli.h"
#include "percentile.h"

namespace {

using namespace gauss;
using gauss::apps::percentile;
using namespace gauss::bench;
using nlohmann::json;

struct ClientBenchOptions {
  std::size_t gaussians{600000};
  std::uint32_t budget{200000};
  std::string size{"320x240"};
  std::uint32_t frames_in_flight{2};
  double timeout_s{600.0};
  std::uint32_t idle_frames{30};
  std::uint32_t teleports{4};
  std::string json_out;
  bool teleport{true};
  bool calibrate{true};
  bool throughput{true};
  bool isolate_host{false};
  bool publication_thread{true};
};

// --isolate-host: the host's threads on the last CPU, the client's (display thread,
// lavapipe's workers, the network thread) on the others, so the host's select + diff +
// encode burst after a teleport cannot take the client's cores, as a host on its own
// machine would not. Threads inherit the affinity of the thread that creates them, so
// the calling thread is pinned to the host's CPU while the host starts and to the
// client's CPUs before the Vulkan device (and its worker threads) is created.
struct CpuSplit {
  cpu_set_t host, client;
};
Expected<CpuSplit> split_cpus() {
  cpu_set_t all;
  CPU_ZERO(&all);
  if (sched_getaffinity(0, sizeof all, &all) != 0) return Error{"cannot read the CPU affinity"};
  std::vector<int> cpus;
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(c, &all)) cpus.push_back(c);
  if (cpus.size() < 2) return Error{"--isolate-host needs at least 2 CPUs, this process may use " + std::to_string(cpus.size())};
  CpuSplit s;
  CPU_ZERO(&s.host);
  CPU_ZERO(&s.client);
  CPU_SET(cpus.back(), &s.host);
  for (std::size_t k = 0; k + 1 < cpus.size(); ++k) CPU_SET(cpus[k], &s.client);
  return s;
}
bool pin_this_thread(const cpu_set_t& set) { return pthread_setaffinity_np(pthread_self(), sizeof set, &set) == 0; }


json pct(const std::vector<double>& v) {
  return json{{"p50", percentile(v, 0.5)}, {"p95", percentile(v, 0.95)}, {"p99", percentile(v, 0.99)}, {"n", v.size()}};
}

// Percentiles and the maximum (a bound is about the worst frame).
json pct_max(const std::vector<double>& v) {
  json j = pct(v);
  j["max"] = v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
  return j;
}

// The in-process host: the synthetic room, fully produced, served on a loopback port by
// its own thread.
class LoopbackHost {
 public:
  static Expected<std::unique_ptr<LoopbackHost>> start(std::size_t gaussians) {
    std::unique_ptr<LoopbackHost> h(new LoopbackHost);
    SyntheticSceneConfig sc;
    sc.target_gaussians = gaussians;
    sc.epochs = 6;
    auto scene = SyntheticScene::create(sc);
    if (!scene) return scene.error();
    while (!scene->finished())
      if (auto s = scene->produce(h->store_); !s) return s.error();
    h->room_min_ = scene->room_min();
    h->room_max_ = scene->room_max();
    CodecParams params;
    params.sh_degree = 1;
    params.box.min = h->room_min_ - glm::vec3(0.5f);
    params.box.max = h->room_max_ + glm::vec3(0.5f);
    net::SessionHostConfig hc;
    hc.net.bind = net::Endpoint{"127.0.0.1", 0};
    auto host = net::SessionHost::start(hc, params);
    if (!host) return host.error();
    h->host_ = std::move(*host);
    h->thread_ = std::thread([p = h.get()] { p->loop(); });
    return h;
  }
  ~LoopbackHost() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  net::Endpoint endpoint() const { return net::Endpoint{"127.0.0.1", host_->net().port()}; }
  glm::vec3 room_min() const { return room_min_; }
  glm::vec3 room_max() const { return room_max_; }
  std::size_t scene_size() const { return store_.size(); }

 private:
  LoopbackHost() = default;
  void loop() {
    const auto t0 = Clock::now();
    while (!stop_) {
      host_->pump(store_, 1e-3 * ms_since(t0));
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  }
  SceneStore store_;
  glm::vec3 room_min_{0.0f}, room_max_{0.0f};
  std::unique_ptr<net::SessionHost> host_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
};

Camera room_camera(const LoopbackHost& h, std::uint32_t w, std::uint32_t hgt, bool far_end) {
  // A: near one end facing that end's wall (-x); B: the far end facing the other (+x).
  const glm::vec3 lo = h.room_min(), hi = h.room_max();
  const double x = lo.x + (far_end ? 0.8 : 0.2) * (hi.x - lo.x), z = lo.z + 0.5 * (hi.z - lo.z);
  const glm::dvec3 eye(x, 1.6, z), target(far_end ? hi.x + 1.0 : lo.x - 1.0, 1.2, z);
  Camera c;
  c.width = w;
  c.height = hgt;
  c.fx = c.fy = 0.6 * w;
  c.cx = 0.5 * w;
  c.cy = 0.5 * hgt;
  c.world_to_camera = glm::inverse(opencv_look_at(eye, target, glm::dvec3(0, 1, 0)));
  return c;
}

// A client runtime connected (connecting, in the background) to the loopback host.
Expected<std::unique_ptr<client::ClientRuntime>> connected_client(vk::Context& ctx, const LoopbackHost& host,
                                                                  std::uint32_t budget, std::string name,
                                                                  PublishMode mode, std::uint32_t frames_in_flight,
                                                                  std::uint32_t w, std::uint32_t h,
                                                                  bool publication_thread) {
  client::ClientRuntimeConfig cfg;
  cfg.publication_thread = publication_thread;
  cfg.state.capacity = budget;
  cfg.state.name = std::move(name);
  cfg.state.publisher.mode = mode;
  cfg.frames_in_flight = frames_in_flight;
  cfg.max_width = w;
  cfg.max_height = h;
  auto rt = client::ClientRuntime::create(ctx, cfg);
  if (!rt) return rt.error();
  net::NetClientConfig nc;
  nc.server = host.endpoint();
  if (auto st = (*rt)->connect(nc); !st) return st.error();
  return rt;
}

struct Settle {
  bool converged{false};
  std::vector<double> frame_ms;  // display-frame intervals until converged
  // Display-thread CPU per frame until converged: ClientState::frame (publication policy)
  // and packing into the staging ring.
  std::vector<double> publish_ms, upload_ms, lock_wait_ms;
  // The display thread's CPU time in the same two stages (lock wait excluded).
  std::vector<double> publish_cpu_ms, upload_cpu_ms;
  // The publication step's own CPU (on the publication thread when it runs there), per
  // frame that took a step: ClientState::frame, and packing its slots.
  std::vector<double> step_publish_cpu_ms, step_pack_cpu_ms;
  std::vector<std::uint32_t> slot_writes;  // slots written or cleared per frame
  // Work per frame: arrivals ranked, ranked candidates touched by the upkeep, slots the
  // upload wrote or cleared, buffer copy regions recorded, and the pieces the compute
  // scatter copied instead (StagedUploads applies many-region groups so).
  std::vector<double> ranked, touched, slots_uploaded, copy_regions, scatter_pieces;
  // GPU side, per finished frame (in frame order): the view's whole GPU time, its blend
  // pass, and the splats it binned and the (tile, splat) pairs it blended.
  std::vector<double> gpu_ms, blend_ms;
  std::vector<std::uint32_t> visible, pairs;
  std::uint64_t frames{0};
  double seconds{0.0};
  std::string error;  // the frame error that ended the run early
};

// Renders frames at `cam` until nothing is pending and nothing new arrived for `quiet_s`.
Settle run_until_settled(client::ClientRuntime& rt, const Camera& cam, double timeout_s, double quiet_s = 0.75) {
  Settle s;
  const auto t0 = Clock::now();
  auto last = t0;
  double quiet_since = -1.0;
  std::uint64_t last_edits = ~0ull;
  double converged_at = -1.0;
  rt.take_gpu_stats();  // frames before this run are not its own
  while (1e-3 * ms_since(t0) < timeout_s) {
    auto f = rt.frame(std::span<const Camera>(&cam, 1));
    const auto now = Clock::now();
    s.frame_ms.push_back(std::chrono::duration<double, std::milli>(now - last).count());
    last = now;
    ++s.frames;
    if (!f) {
      s.error = f.message();
      break;
    }
    s.publish_ms.push_back(f->publish_ms);
    s.upload_ms.push_back(f->upload_ms);
    s.lock_wait_ms.push_back(f->lock_wait_ms);
    s.publish_cpu_ms.push_back(f->publish_cpu_ms);
    s.upload_cpu_ms.push_back(f->upload_cpu_ms);
    if (f->step_taken) {
      s.step_publish_cpu_ms.push_back(f->step_publish_cpu_ms);
      s.step_pack_cpu_ms.push_back(f->step_pack_cpu_ms);
    }
    s.slot_writes.push_back(f->publish.slot_writes());
    s.ranked.push_back(f->publish.ranked);
    s.touched.push_back(f->publish.touched);
    s.slots_uploaded.push_back(f->uploaded.slots_written + f->uploaded.slots_cleared);
    s.copy_regions.push_back(f->copy_regions);
    s.scatter_pieces.push_back(f->scatter_pieces);
    // The counters as of the step this frame took, not rt.with_state(): the state's lock is
    // held by the publication thread's step, and waiting for it here made every frame
    // without a step last that step's time (H100: 1.0-1.35 ms, alternating with 0.1 ms,
    // while the display thread's own work stayed under 0.03 ms).
    const std::uint64_t edits = f->counters.edits_received;
    const double t = 1e-3 * ms_since(t0);
    const bool idle = f->pending == 0 && f->publish.slot_writes() == 0 && f->desired > 0;
    if (edits != last_edits || !idle) {
      last_edits = edits;
      quiet_since = t;
      converged_at = -1.0;
      continue;
    }
    if (converged_at < 0.0) converged_at = t;
    if (t - quiet_since >= quiet_s) {
      s.converged = true;
      s.seconds = converged_at;
      // Drop the idle frames after convergence from the streaming interval list.
      while (s.frame_ms.size() > 1 && s.frames > 1 && s.frame_ms.size() > s.frames - 1) s.frame_ms.pop_back();
      break;
    }
  }
  // The GPU figures of the run's frames, read once at the end: ClientRuntime collects each
  // finished frame's statistics itself, and reading them here every frame changed the pacing
  // it measures (intervals alternating near 0 and twice the frame).
  if (auto st = rt.wait_frames(); !st && s.error.empty()) s.error = st.message();
  for (const client::GpuFrameStats& g : rt.take_gpu_stats()) {
    s.gpu_ms.push_back(g.total_ms);
    s.blend_ms.push_back(g.view[0].gpu.blend_ms);
    s.visible.push_back(g.view[0].visible);
    s.pairs.push_back(g.view[0].pairs);
  }
  return s;
}

std::vector<double> idle_frames(client::ClientRuntime& rt, const Camera& cam, std::uint32_t n) {
  std::vector<double> ms;
  auto last = Clock::now();
  for (std::uint32_t k = 0; k < n + 1; ++k) {
    if (!rt.frame(std::span<const Camera>(&cam, 1))) break;
    const auto now = Clock::now();
    if (k > 0) ms.push_back(std::chrono::duration<double, std::milli>(now - last).count());
    last = now;
  }
  return ms;
}

json bench_teleport(vk::Context& ctx, const ClientBenchOptions& o, LoopbackHost& host, PublishMode mode, std::uint32_t w,
                    std::uint32_t h) {
  const char* name = mode == PublishMode::Immediate ? "immediate" : "progressive";
  auto rt = connected_client(ctx, host, o.budget, std::string("bench-") + name, mode, o.frames_in_flight, w, h,
                             o.publication_thread);
  if (!rt) return json{{"mode", name}, {"error", rt.message()}};
  const Camera a = room_camera(host, w, h, false), b = room_camera(host, w, h, true);
  auto failed = [&](const Settle& s, const char* where) {
    return json{{"mode", name}, {"error", s.error.empty() ? std::string("did not converge ") + where : s.error}};
  };
  const Settle first = run_until_settled(**rt, a, o.timeout_s);
  if (!first.converged) return failed(first, "at A");
  const std::vector<double> idle_before = idle_frames(**rt, a, o.idle_frames);
  // The display this device drives: its idle frame interval with 25 % headroom (lavapipe
  // cannot reach a headset's 72-90 Hz). Progressive publication keeps frames within it.
  const double period_s = 1.25e-3 * percentile(idle_before, 0.5);
  (*rt)->set_display_period(period_s);
  // Far teleports A -> B -> A ...: the streaming frames of all of them are pooled, and so
  // are the idle frames after each, so a p99 rests on more than a few dozen frames.
  std::vector<double> streaming, idle_after, publish, upload, lock_wait, convergence, net_cpu;
  std::vector<double> publish_cpu, upload_cpu, ranked, touched, slots_uploaded, copy_regions, scatter_pieces;
  std::vector<double> step_publish_cpu, step_pack_cpu;
  json series = json::array();
  for (std::uint32_t t = 0; t < o.teleports; ++t) {
    const Camera& to = t % 2 == 0 ? b : a;
    const double net0 = (*rt)->connection().counters.thread_cpu_ms;
    const Settle tele = run_until_settled(**rt, to, o.timeout_s);
    if (!tele.converged) return failed(tele, "after a teleport");
    net_cpu.push_back((*rt)->connection().counters.thread_cpu_ms - net0);
    convergence.push_back(tele.seconds);
    streaming.insert(streaming.end(), tele.frame_ms.begin(), tele.frame_ms.end());
    publish.insert(publish.end(), tele.publish_ms.begin(), tele.publish_ms.end());
    upload.insert(upload.end(), tele.upload_ms.begin(), tele.upload_ms.end());
    lock_wait.insert(lock_wait.end(), tele.lock_wait_ms.begin(), tele.lock_wait_ms.end());
    publish_cpu.insert(publish_cpu.end(), tele.publish_cpu_ms.begin(), tele.publish_cpu_ms.end());
    upload_cpu.insert(upload_cpu.end(), tele.upload_cpu_ms.begin(), tele.upload_cpu_ms.end());
    step_publish_cpu.insert(step_publish_cpu.end(), tele.step_publish_cpu_ms.begin(), tele.step_publish_cpu_ms.end());
    step_pack_cpu.insert(step_pack_cpu.end(), tele.step_pack_cpu_ms.begin(), tele.step_pack_cpu_ms.end());
    ranked.insert(ranked.end(), tele.ranked.begin(), tele.ranked.end());
    touched.insert(touched.end(), tele.touched.begin(), tele.touched.end());
    slots_uploaded.insert(slots_uploaded.end(), tele.slots_uploaded.begin(), tele.slots_uploaded.end());
    copy_regions.insert(copy_regions.end(), tele.copy_regions.begin(), tele.copy_regions.end());
    scatter_pieces.insert(scatter_pieces.end(), tele.scatter_pieces.begin(), tele.scatter_pieces.end());
    series.push_back(json{{"frame_ms", tele.frame_ms}, {"publish_ms", tele.publish_ms}, {"upload_ms", tele.upload_ms},
                          {"lock_wait_ms", tele.lock_wait_ms}, {"publish_thread_cpu_ms", tele.publish_cpu_ms},
                          {"upload_thread_cpu_ms", tele.upload_cpu_ms}, {"ranked", tele.ranked},
                          {"touched", tele.touched}, {"copy_regions", tele.copy_regions},
                          {"scatter_pieces", tele.scatter_pieces},
                          {"slot_writes", tele.slot_writes}, {"gpu_ms", tele.gpu_ms}, {"blend_ms", tele.blend_ms},
                          {"visible", tele.visible}, {"pairs", tele.pairs}});
    const std::vector<double> idle = idle_frames(**rt, to, o.idle_frames);
    idle_after.insert(idle_after.end(), idle.begin(), idle.end());
  }
  const std::uint32_t resident = (*rt)->with_state([](const ClientState& s) { return s.slots().size(); });
  const auto ss = (*rt)->publication().stats();
  std::printf("   %-12s %8.2f %8zu %9.1f %9.1f %9.1f   %9.1f %9.1f %9.1f  %8u  %6.2f/%6.2f  %6.2f/%6.2f  %8.0f\n", name,
              median(convergence), streaming.size(), percentile(streaming, 0.5), percentile(streaming, 0.95),
              percentile(streaming, 0.99), percentile(idle_after, 0.5), percentile(idle_after, 0.95),
              percentile(idle_after, 0.99), resident, percentile(publish_cpu, 0.5), percentile(publish_cpu, 0.99),
              percentile(upload_cpu, 0.5), percentile(upload_cpu, 0.99), median(net_cpu));
  auto worst = [](const std::vector<double>& v) { return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end()); };
  std::printf("   %-12s work per frame p99/max: ranked %.0f/%.0f, touched %.0f/%.0f, slots uploaded %.0f/%.0f, "
              "copy regions %.0f/%.0f, scatter pieces %.0f/%.0f\n", "", percentile(ranked, 0.99), worst(ranked),
              percentile(touched, 0.99), worst(touched), percentile(slots_uploaded, 0.99), worst(slots_uploaded),
              percentile(copy_regions, 0.99), worst(copy_regions), percentile(scatter_pieces, 0.99), worst(scatter_pieces));
  std::printf("   %-12s wall ms p99/max: publish %.2f/%.2f (lock wait %.2f/%.2f), upload %.2f/%.2f\n", "",
              percentile(publish, 0.99), worst(publish), percentile(lock_wait, 0.99), worst(lock_wait),
              percentile(upload, 0.99), worst(upload));
  std::printf("   %-12s publication step CPU ms p99/max (%s): ClientState::frame %.2f/%.2f, packing %.2f/%.2f\n",
              "", o.publication_thread ? "on the publication thread" : "on the display thread, as above",
              percentile(step_publish_cpu, 0.99), worst(step_publish_cpu), percentile(step_pack_cpu, 0.99),
              worst(step_pack_cpu));
  return json{{"mode", name},
              {"display_period_ms", period_s * 1e3},
              {"teleports", o.teleports},
              {"convergence_s", median(convergence)},
              {"convergence_s_each", convergence},
              {"streaming_frames", streaming.size()},
              {"frame_ms_streaming", pct(streaming)},
              {"frame_ms_idle_before", pct(idle_before)},
              {"frame_ms_idle_after", pct(idle_after)},
              {"idle_frames_after", idle_after.size()},
              // Wall times (these two keys were named before thread CPU was measured).
              {"publish_cpu_ms_streaming", pct(publish)},
              {"upload_cpu_ms_streaming", pct(upload)},
              {"publish_wall_ms_streaming", pct_max(publish)},
              {"upload_wall_ms_streaming", pct_max(upload)},
              {"publish_thread_cpu_ms_streaming", pct_max(publish_cpu)},
              {"upload_thread_cpu_ms_streaming", pct_max(upload_cpu)},
              {"step_publish_thread_cpu_ms_streaming", pct_max(step_publish_cpu)},
              {"step_pack_thread_cpu_ms_streaming", pct_max(step_pack_cpu)},
              {"work_per_frame_streaming",
               {{"arrivals_ranked", pct_max(ranked)},
                {"backlog_items_touched", pct_max(touched)},
                {"slots_written", pct_max(slots_uploaded)},
                {"copy_regions", pct_max(copy_regions)},
                {"scatter_pieces", pct_max(scatter_pieces)}}},
              {"lock_wait_ms_streaming", pct_max(lock_wait)},
              {"network_thread_cpu_ms_each", net_cpu},
              {"p99_over_idle_p99", percentile(streaming, 0.99) / std::max(1e-9, percentile(idle_after, 0.99))},
              {"resident", resident},
              {"slots_uploaded_total", ss.slots_written + ss.slots_cleared},
              {"first_convergence_s", first.seconds},
              {"series", series}};
}

// Least squares y = c0 + c1 x1 + c2 x2 (normal equations, 3x3).
std::array<double, 3> fit3(const std::vector<std::array<double, 3>>& rows, const std::vector<double>& y) {
  double a[3][4] = {};
  for (std::size_t i = 0; i < rows.size(); ++i)
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) a[r][c] += rows[i][r] * rows[i][c];
      a[r][3] += rows[i][r] * y[i];
    }
  for (int p = 0; p < 3; ++p) {
    int best = p;
    for (int r = p + 1; r < 3; ++r)
      if (std::abs(a[r][p]) > std::abs(a[best][p])) best = r;
    std::swap(a[p], a[best]);
    if (std::abs(a[p][p]) < 1e-30) return {0, 0, 0};
    for (int r = 0; r < 3; ++r) {
      if (r == p) continue;
      const double f = a[r][p] / a[p][p];
      for (int c = p; c < 4; ++c) a[r][c] -= f * a[p][c];
    }
  }
  return {a[0][3] / a[0][0], a[1][3] / a[1][1], a[2][3] / a[2][2]};
}

json bench_calibration(vk::Context& ctx, const ClientBenchOptions& o, LoopbackHost& host, std::uint32_t w, std::uint32_t h) {
  // A converged client at A, then blocking frames (one in flight) with K slots rewritten
  // (their own records: the image stays) in R runs. A whole lavapipe frame varies by tens
  // of ms from run to run, far more than uploads cost, so the upload is measured on its
  // own: CPU time packing into the staging ring + GPU time of the frame's copies
  // (timestamps around them), fitted as a K + b R + c; the base is the median idle frame.
  auto rt = connected_client(ctx, host, o.budget, "bench-calibration", PublishMode::Immediate, 1, w, h, false);
  if (!rt) return json{{"error", rt.message()}};
  const Camera a = room_camera(host, w, h, false);
  if (!run_until_settled(**rt, a, o.timeout_s).converged) return json{{"error", "did not converge"}};
  std::vector<Gaussian> records = (*rt)->with_state([](const ClientState& s) {
    const auto r = s.slots().records();
    return std::vector<Gaussian>(r.begin(), r.end());
  });
  render::SplatRenderer& r = (*rt)->renderer();
  std::vector<double> idle_wall;
  for (int k = 0; k < 7; ++k) {
    const auto t0 = Clock::now();
    if (!r.render(a)) return json{{"error", "render failed"}};
    idle_wall.push_back(ms_since(t0));
  }
  const double base_ms = median(idle_wall);
  const std::uint32_t cap = o.budget;
  const std::uint32_t ks[] = {2000, 10000, 40000, 100000, 200000};
  const std::uint32_t runs_per_k[] = {1, 16, 256, 2048, 8192};
  std::vector<std::array<double, 3>> rows;
  std::vector<double> upload_ms;
  json samples = json::array();
  std::printf("   idle frame %.1f ms (median of 7; spread %.1f-%.1f)\n", base_ms,
              *std::min_element(idle_wall.begin(), idle_wall.end()), *std::max_element(idle_wall.begin(), idle_wall.end()));
  std::printf("   %9s %7s %12s %12s %12s %10s\n", "writes", "ranges", "pack cpu ms", "copy gpu ms", "upload ms", "fit ms");
  for (std::uint32_t k : ks)
    for (std::uint32_t runs : runs_per_k) {
      if (runs > k / 4) continue;
      std::vector<double> cpus, gpus;
      for (int rep = 0; rep < 3; ++rep) {
        const double c0 = thread_cpu_ms();
        // R runs of K/R slots spread evenly over the slots.
        const std::uint32_t per = k / runs, stride = cap / runs;
        for (std::uint32_t i = 0; i < runs; ++i) {
          const std::uint32_t first = i * stride;
          const std::uint32_t n = std::min(per, cap - first);
          if (!r.write_slots(first, std::span<const Gaussian>(records.data() + first, n)))
            return json{{"error", "write_slots failed"}};
        }
        cpus.push_back(thread_cpu_ms() - c0);
        auto st = r.render(a);
        if (!st) return json{{"error", st.message()}};
        gpus.push_back(st->gpu.upload_ms);
      }
      const double cpu = median(cpus), gpu = median(gpus);
      rows.push_back({1.0, static_cast<double>(k), static_cast<double>(runs)});
      upload_ms.push_back(cpu + gpu);
      samples.push_back(json{{"writes", k}, {"ranges", runs}, {"pack_cpu_ms", cpu}, {"copy_gpu_ms", gpu}});
    }
  const auto c = fit3(rows, upload_ms);
  double ss = 0.0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const double fit = c[0] + c[1] * rows[i][1] + c[2] * rows[i][2];
    ss += (fit - upload_ms[i]) * (fit - upload_ms[i]);
    std::printf("   %9.0f %7.0f %12.2f %12.2f %12.2f %10.2f\n", rows[i][1], rows[i][2],
                samples[i]["pack_cpu_ms"].get<double>(), samples[i]["copy_gpu_ms"].get<double>(), upload_ms[i], fit);
  }
  const double rms = std::sqrt(ss / static_cast<double>(rows.size()));
  std::printf("   fit: frame = %.2f ms (idle) + %.2f ms + %.4f us/write + %.3f us/range (upload fit RMS residual %.2f ms)\n",
              base_ms, c[0], c[1] * 1e3, c[2] * 1e3, rms);
  std::printf("   the simulation's default constants: 7.00 ms + 0.1500 us/write + 2.000 us/range (a modelled headset)\n");
  std::printf("   for gauss-bench stream: --frame-cost %.3f,%.5f,%.4f\n", base_ms + std::max(0.0, c[0]),
              std::max(0.0, c[1] * 1e3), std::max(0.0, c[2] * 1e3));
  return json{{"base_ms", base_ms + std::max(0.0, c[0])},
              {"idle_frame_ms", base_ms},
              {"upload_intercept_ms", c[0]},
              {"per_write_us", c[1] * 1e3},
              {"per_range_us", c[2] * 1e3},
              {"upload_fit_rms_ms", rms},
              {"model_constants", {{"base_ms", 7.0}, {"per_write_us", 0.15}, {"per_range_us", 2.0}}},
              {"samples", samples}};
}

json bench_throughput(vk::Context& ctx) {
  const VkDeviceSize total = 200000ull * 64;  // 200k core records
  auto dst = vk::Buffer::create(ctx, {.size = total, .name = "throughput destination"});
  auto slow_dst = vk::Buffer::create(ctx, {.size = total, .name = "throughput destination (no map)", .never_map = true});
  auto ring = vk::FrameRing::create(ctx, 2);
  if (!dst || !slow_dst || !ring) return json{{"error", "allocation failed"}};
  auto up = vk::StagedUploads::create(ctx, **ring, {.initial_bytes = total + (1 << 20)});
  if (!up) return json{{"error", up.message()}};
  std::vector<std::uint8_t> src(total);
  std::iota(src.begin(), src.end(), std::uint8_t{0});
  json out = json::array();
  std::printf("   %8s %18s %22s\n", "ranges", "staging ring GiB/s", "per-call staging GiB/s");
  for (std::uint32_t runs : {1u, 64u, 4096u}) {
    const VkDeviceSize per = total / runs;
    std::vector<double> ring_s, call_s;
    for (int rep = 0; rep < 5; ++rep) {
      auto t0 = Clock::now();
      for (std::uint32_t i = 0; i < runs; ++i)
        if (auto st = (*up)->write(*dst, i * per, src.data() + i * per, per); !st) return json{{"error", st.message()}};
      auto f = (*ring)->begin();
      if (!f) return json{{"error", f.message()}};
      (*up)->record(f->cmd);
      if (!(*ring)->submit()) return json{{"error", "submit failed"}};
      (*up)->submitted();
      if (!(*ring)->wait_all()) return json{{"error", "wait failed"}};
      ring_s.push_back(1e-3 * ms_since(t0));
      t0 = Clock::now();
      for (std::uint32_t i = 0; i < runs; ++i)
        if (!slow_dst->upload(src.data() + i * per, per, i * per)) return json{{"error", "upload failed"}};
      call_s.push_back(1e-3 * ms_since(t0));
    }
    const double gib = static_cast<double>(per * runs) / (1024.0 * 1024.0 * 1024.0);
    const double ring_gibs = gib / median(ring_s), call_gibs = gib / median(call_s);
    std::printf("   %8u %18.2f %22.2f\n", runs, ring_gibs, call_gibs);
    out.push_back(json{{"ranges", runs}, {"bytes", per * runs}, {"staging_ring_gib_s", ring_gibs},
                       {"per_call_staging_gib_s", call_gibs}});
  }
  return out;
}

int bench_client_main(const ClientBenchOptions& o) {
  const auto wh = apps::parse_size(o.size);
  const std::uint32_t w = wh->first, h = wh->second;
  std::optional<CpuSplit> split;
  if (o.isolate_host) {
    auto s = split_cpus();
    if (!s) {
      std::fprintf(stderr, "gauss-bench client: %s\n", s.message().c_str());
      return 1;
    }
    split = *s;
  }
  // The host first (its threads inherit the host CPU when isolated), then the client's
  // Vulkan device on the client CPUs.
  std::unique_ptr<LoopbackHost> host;
  json doc{{"budget", o.budget}, {"size", o.size}, {"frames_in_flight", o.frames_in_flight}, {"publication_thread", o.publication_thread},
           {"isolate_host", o.isolate_host}};
  if (o.teleport || o.calibrate) {
    if (split && !pin_this_thread(split->host)) {
      std::fprintf(stderr, "gauss-bench client: cannot pin the host's threads\n");
      return 1;
    }
    const auto t0 = Clock::now();
    auto hs = apps::with_elapsed_status("gauss-bench client: producing the room",
                                        [&] { return LoopbackHost::start(o.gaussians); });
    if (!hs) {
      std::fprintf(stderr, "gauss-bench client: %s\n", hs.message().c_str());
      return 1;
    }
    host = std::move(*hs);
    std::printf("host: synthetic room of %zu Gaussians on %s (%.1f s to produce)\n", host->scene_size(),
                net::to_string(host->endpoint()).c_str(), 1e-3 * ms_since(t0));
    doc["scene_gaussians"] = host->scene_size();
  }
  if (split && !pin_this_thread(split->client)) {
    std::fprintf(stderr, "gauss-bench client: cannot pin the client's threads\n");
    return 1;
  }
  auto ctx = vk::Context::create({.app_name = "gauss-bench client"});
  if (!ctx) {
    std::fprintf(stderr, "gauss-bench client: %s\n", ctx.message().c_str());
    return 1;
  }
  doc["device"] = (*ctx)->device_name();
  std::printf("gauss-bench client: device %s, M = %u, %ux%u, %u frames in flight, publication %s%s\n",
              (*ctx)->device_name().c_str(), o.budget, w, h, o.frames_in_flight,
              o.publication_thread ? "on its own thread" : "on the display thread",
              o.isolate_host ? "; host threads on the last CPU, the client's on the others" : "");
  if (o.throughput) {
    std::printf("\n3. upload throughput, 200k x 64 B records (wall, median of 5)\n");
    doc["throughput"] = bench_throughput(**ctx);
  }
  if (o.calibrate) {
    std::printf("\n2. frame cost calibration at A (blocking frames, median of 3)\n");
    doc["calibration"] = bench_calibration(**ctx, o, *host, w, h);
  }
  if (o.teleport) {
    std::printf("\n1. far teleport over loopback (display period: 1.25 x the idle frame interval at A)\n");
    std::printf("   %u teleports per mode, their streaming frames pooled; idle: the frames after each\n", o.teleports);
    std::printf("   %-12s %8s %8s %9s %9s %9s   %9s %9s %9s  %8s  %13s  %13s  %8s\n", "mode", "conv s", "frames",
                "p50 ms", "p95 ms", "p99 ms", "idle p50", "idle p95", "idle p99", "resident", "publish p50/99",
                "upload p50/99", "net cpu");
    std::printf("   (publish, upload: the display thread's CPU ms in each, CLOCK_THREAD_CPUTIME_ID; wall ms below)\n");
    if (!o.isolate_host)
      std::printf("   (the host runs in this process, on the same cores: its select + diff + encode after the\n"
                  "    teleport competes with the client's frames, which a headset's would not; see --isolate-host)\n");
    doc["teleport"] = json::array({bench_teleport(**ctx, o, *host, PublishMode::Immediate, w, h),
                                   bench_teleport(**ctx, o, *host, PublishMode::Progressive, w, h)});
  }
  doc["validation_errors"] = (*ctx)->validation_error_count();
  if (!o.json_out.empty() && !write_json(o.json_out, doc, "client")) return 1;
  // A part that failed (a client error, no convergence) is a failed run, not a missing row.
  bool failed = false;
  if (doc.contains("teleport"))
    for (const json& t : doc["teleport"])
      if (t.contains("error")) {
        std::fprintf(stderr, "gauss-bench client: teleport (%s): %s\n", t.value("mode", "?").c_str(),
                     t["error"].get<std::string>().c_str());
        failed = true;
      }
  return failed ? 1 : 0;
}

BenchRun bench_client_setup(CLI::App& cmd) {
  auto o = std::make_shared<ClientBenchOptions>();
  cmd.add_option("--gaussians", o->gaussians, "Gaussians in the synthetic room the host serves")
      ->check(apps::at_least<std::size_t>(1000));
  cmd.add_option("--budget", o->budget, "M: the client's slots")->check(apps::in_range<std::uint32_t>(1, 400000));
  cmd.add_option("--size", o->size, "view size")->check(apps::image_size());
  cmd.add_option("--frames-in-flight", o->frames_in_flight, "frames in flight of the streaming client")
      ->check(apps::in_range<std::uint32_t>(1, 4));
  cmd.add_option("--timeout", o->timeout_s, "longest wait for a convergence, seconds")->check(apps::at_least(1.0));
  cmd.add_option("--idle-frames", o->idle_frames, "idle frames measured at each end")->check(apps::at_least(2u));
  cmd.add_option("--teleports", o->teleports, "far teleports per mode (A -> B -> A ...), their frames pooled")
      ->check(apps::in_range<std::uint32_t>(1, 100));
  cmd.add_option("--json", o->json_out, "also write the results as JSON to FILE");
  apps::add_on_off(cmd, "--publication-thread", o->publication_thread,
                   "publish and pack on a thread of the client's own, or on the display thread");
  cmd.add_flag("--isolate-host", o->isolate_host,
               "run the in-process host's threads on the last CPU and the client's on the others");
  cmd.add_flag_callback("--no-teleport", [o] { o->teleport = false; }, "skip part 1");
  cmd.add_flag_callback("--no-calibration", [o] { o->calibrate = false; }, "skip part 2");
  cmd.add_flag_callback("--no-throughput", [o] { o->throughput = false; }, "skip part 3");
  return [o] { return bench_client_main(*o); };
}

}  // namespace

GAUSS_BENCH("client", "the real client path: loopback teleport frame times per mode, frame cost calibration, upload GiB/s",
            bench_client_setup);
