// gauss-bench stream: the client streaming policy and the deterministic simulation.
//   1. coalescing throughput: DesiredState::apply on one core (edits/s), inserts,
//      coalesced updates of pending ids, and a mixed stream;
//   2. far-teleport convergence at budget M over a modelled link (default 100 Mbit/s,
//      5 ms) with a 72 Hz display, per publication mode, with post-convergence flicker;
//   3. upload ranges per frame vs slot writes per frame while converging;
//   4. bytes on the wire per second in steady state (scene evolving, viewer still);
//   5. the cost of a sealed stream (gauss-host --encrypt): seal and open throughput per
//      frame size on one core (thread CPU), and what that adds to the teleport's bytes.
// Definitions (also in the JSON):
//   convergence time: from the teleport (the viewer's pose jumps) to the first display
//     frame from which the client's published set equals its desired set and stays so,
//     with the desired set final (the host sends nothing more); the end state is checked
//     exactly (published = desired = the host's intended set, by checksum).
//   churn: published-set membership changes (an id entering or leaving the published
//     set) per second during a 6 s window after convergence, while the scene is static
//     and the head only sways (5 cm / 3 cm / 3 deg sinusoids, sampled at the 10 Hz pose
//     rate). The window spans a whole period of every sinusoid (2.2 s, 3.3 s, 5 s): a
//     shorter one can end before the head swings back, and then a set that follows the
//     sway shows churn but no flicker by luck of timing.
//   flicker: the part of that churn undone within the window (an id that left and came
//     back, or came and left again) = changes - |start set XOR end set|. Target 0.
// All times are virtual (simulation clock), so they reproduce exactly; the frame cost
// model (sim.h FrameCostModel) stands in for the GPU. Timing never decides a test.
#include <algorithm>
#include <iterator>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench_registry.h"
#include "bench_util.h"
#include "gauss_cli.h"
#include "gauss/engine/desired_state.h"
#include "gauss/engine/sim.h"
#include "gauss/net/auth.h"
#include "gauss/net/stream_cipher.h"
#include "percentile.h"

namespace {

using namespace gauss::bench;

using namespace gauss;
using namespace gauss::sim;
using nlohmann::json;

struct StreamBenchOptions {
  std::uint32_t budget{200000};
  std::size_t scene_gaussians{600000};
  std::size_t coalesce_ids{1000000};
  double bandwidth_bps{100e6};
  double latency_s{0.005};
  double display_hz{72.0};
  std::string json_out;
  bool teleport{true};
  bool steady{true};
  bool sealed{true};
  double pose_smoothing_s{-1.0};  // < 0: HostSessionConfig's default
  // --frame-cost: a frame cost model measured on a device (gauss-bench client's
  // calibration); the teleport then also runs with it, beside the default constants.
  std::optional<FrameCostModel> calibrated;
  FrameCostModel cost{};          // the model of the current run
  std::string cost_label{"model"};
};

double seconds_since(Clock::time_point t0) { return 1e-3 * ms_since(t0); }

Gaussian record(std::uint64_t i, float v) {
  Gaussian g;
  g.position = {static_cast<float>(i % 1000) * 0.01f, v, 1.0f};
  g.sh_dc = {v, 0.5f, 0.25f};
  g.opacity_logit = 1.0f;
  g.support = 4;
  g.id = GaussianId{i};
  return g;
}

// ---- 1. coalescing ------------------------------------------------------------------

json bench_coalescing(const StreamBenchOptions& o) {
  const std::size_t n = o.coalesce_ids;
  std::mt19937_64 rng(1);
  EditBatch inserts{Epoch{1}, {}};
  inserts.edits.reserve(n);
  for (std::size_t i = 0; i < n; ++i) inserts.edits.push_back(Edit{EditKind::Insert, GaussianId{i + 1}, GaussianId{0}, record(i + 1, 0.0f)});
  std::vector<EditBatch> updates;
  for (int b = 0; b < 4; ++b) {
    EditBatch u{Epoch{static_cast<std::uint64_t>(2 + b)}, {}};
    u.edits.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint64_t id = 1 + rng() % n;
      u.edits.push_back(Edit{EditKind::Update, GaussianId{id}, GaussianId{0}, record(id, static_cast<float>(b + 1))});
    }
    updates.push_back(std::move(u));
  }
  // Construction allocates and touches the index and entry pool for M ids once, as a
  // client does at start-up; reported apart from the per-edit rate.
  double c0 = thread_cpu_s();
  DesiredState d(static_cast<std::uint32_t>(std::min<std::size_t>(n, kMaxSlotCapacity)));
  const double construct_s = thread_cpu_s() - c0;
  c0 = thread_cpu_s();
  auto r = d.apply(inserts, 0.0);
  const double ins_s = thread_cpu_s() - c0;
  if (!r || r->accepted != n) std::fprintf(stderr, "coalescing: inserts rejected: %s\n", r ? r->first_rejection.c_str() : r.message().c_str());
  c0 = thread_cpu_s();
  std::size_t upd_edits = 0;
  for (const auto& u : updates) {
    auto ru = d.apply(u, 1.0);
    upd_edits += u.edits.size();
    if (!ru) std::fprintf(stderr, "coalescing: %s\n", ru.message().c_str());
  }
  const double upd_s = thread_cpu_s() - c0;
  // Mixed: removes of pending inserts (cancel), re-inserts under new ids, updates.
  EditBatch mixed{Epoch{10}, {}};
  std::uint64_t next = n + 1;
  for (std::size_t i = 0; i < n / 3; ++i) {
    const std::uint64_t id = 1 + i * 3;
    mixed.edits.push_back(Edit{EditKind::Remove, GaussianId{id}, GaussianId{0}, {}});
    mixed.edits.push_back(Edit{EditKind::Insert, GaussianId{next}, GaussianId{0}, record(next, 9.0f)});
    ++next;
    mixed.edits.push_back(Edit{EditKind::Update, GaussianId{id + 1}, GaussianId{0}, record(id + 1, 7.0f)});
  }
  c0 = thread_cpu_s();
  auto rm = d.apply(mixed, 2.0);
  const double mix_s = thread_cpu_s() - c0;
  if (!rm || rm->rejected) std::fprintf(stderr, "coalescing: mixed batch had rejections\n");
  const double ins_rate = static_cast<double>(n) / ins_s, upd_rate = static_cast<double>(upd_edits) / upd_s,
               mix_rate = static_cast<double>(mixed.edits.size()) / mix_s;
  std::printf("\n1. coalescing (DesiredState::apply, one thread, %zu ids, nothing published; thread CPU time)\n", n);
  std::printf("   %-34s %12s %14s\n", "stream", "edits", "edits/cpu-s");
  std::printf("   %-34s %12zu %14.3g\n", "inserts", n, ins_rate);
  std::printf("   %-34s %12zu %14.3g\n", "updates of pending ids (coalesced)", upd_edits, upd_rate);
  std::printf("   %-34s %12zu %14.3g\n", "mixed remove/insert/update", mixed.edits.size(), mix_rate);
  std::printf("   pending after: %zu (= desired %zu: every superseded value discarded); target >= 5e6 edits/s\n",
              d.pending_count(), d.desired_count());
  std::printf("   construction (index + entry pool for %zu ids, once per client): %.3f cpu-s\n", n, construct_s);
  return json{{"ids", n},
              {"clock", "thread CPU time"},
              {"insert_edits_per_s", ins_rate},
              {"update_edits_per_s", upd_rate},
              {"mixed_edits_per_s", mix_rate},
              {"construct_cpu_s", construct_s},
              {"superseded", d.stats().superseded},
              {"cancelled", d.stats().cancelled},
              {"pending_after", d.pending_count()}};
}

// ---- 2 + 3. teleport ----------------------------------------------------------------

glm::vec4 yaw(double a) { return glm::vec4(static_cast<float>(std::cos(a * 0.5)), 0.0f, static_cast<float>(std::sin(a * 0.5)), 0.0f); }

SimConfig base_config(const StreamBenchOptions& o, PublishMode mode, bool evolving) {
  SimConfig cfg;
  cfg.seed = 7;
  cfg.scene.seed = 7;
  cfg.scene.target_gaussians = o.scene_gaussians;
  cfg.scene.epochs = evolving ? 40 : 4;
  cfg.scene.cameras_per_epoch = evolving ? 2 : 12;
  cfg.scene.converge_epochs = evolving ? 4 : 1;
  cfg.scene.prune_fraction = evolving ? 0.02f : 0.0f;
  cfg.epoch_period_s = 0.1;
  cfg.cost = o.cost;
  cfg.check_every_frame = false;  // O(M) per frame; the tests check, the bench measures
  cfg.check_coalescing = false;
  if (o.pose_smoothing_s >= 0.0) cfg.host.pose_smoothing_s = o.pose_smoothing_s;
  ClientSpec c;
  c.client.capacity = o.budget;
  c.client.name = mode == PublishMode::Immediate ? "immediate" : "progressive";
  c.client.publisher.mode = mode;
  c.client.publisher.allowance_min = 2000;
  c.client.publisher.allowance_initial = 20000;
  // At 72 Hz (13.9 ms) with a 7 ms render and 0.15 us per slot write, ~40k writes fit.
  c.client.publisher.allowance_max = 40000;
  c.client.publisher.age_escape_s = 0.25;
  c.client.publisher.escape_quota = 5000;
  c.client.range_merge_gap = 4;
  // The frame cost model's price of a copy command, in slot writes (2 us / 0.15 us).
  c.client.publisher.range_cost =
      cfg.cost.per_write_s > 0.0 ? static_cast<float>(cfg.cost.per_range_s / cfg.cost.per_write_s) : 0.0f;
  c.display_hz = o.display_hz;
  c.down.bandwidth_bps = c.up.bandwidth_bps = o.bandwidth_bps;
  c.down.latency_s = c.up.latency_s = o.latency_s;
  cfg.clients = {c};
  return cfg;
}

struct FrameLog {
  std::vector<FrameSample> frames;
};

json bench_teleport(const StreamBenchOptions& o, PublishMode mode) {
  const std::string label = std::string(mode == PublishMode::Immediate ? "immediate" : "progressive") +
                            (o.cost_label == "model" ? "" : "/" + o.cost_label);
  const char* name = label.c_str();
  const auto wall0 = Clock::now();
  auto sim = Simulation::create(base_config(o, mode, false));
  if (!sim) {
    std::fprintf(stderr, "teleport: %s\n", sim.message().c_str());
    return json{{"error", sim.message()}};
  }
  FrameLog log;
  sim->on_frame([&log](const FrameSample& f) { log.frames.push_back(f); });
  const Aabb b = sim->scene().bounds();
  // A: near one end of the room facing that end's wall (-x); B: the far end facing the
  // other wall (+x). The two views share almost nothing: a far teleport.
  const glm::vec3 lo = b.min, hi = b.max;
  const glm::vec3 a_pos(lo.x + 0.2f * (hi.x - lo.x), 1.6f, lo.z + 0.5f * (hi.z - lo.z));
  const glm::vec3 b_pos(lo.x + 0.8f * (hi.x - lo.x), 1.6f, lo.z + 0.5f * (hi.z - lo.z));
  const double a_yaw = -3.14159265 / 2, b_yaw = 3.14159265 / 2;  // OpenCV +z rotated about y
  sim->set_pose(0, a_pos, yaw(a_yaw));
  if (Status s = sim->run_until(0.6); !s) return json{{"error", s.message()}};
  sim->stop_scene();
  if (Status s = sim->run_until_converged(20.0); !s) return json{{"error", s.message()}};
  if (Status s = sim->run_until(sim->now() + 0.5); !s) return json{{"error", s.message()}};
  const std::uint64_t bytes_before = sim->down_link(0).stats().wire_bytes;
  log.frames.clear();
  const double t0 = sim->now();
  sim->set_pose(0, b_pos, yaw(b_yaw));
  // Run until the host has answered the new pose and the client has caught up with
  // everything it sent, then check the exact end state and find the frame.
  const std::uint64_t batch0 = sim->session(0)->last_batch_id();
  for (;;) {
    if (Status s = sim->run_until(sim->now() + 0.01); !s) return json{{"error", s.message()}};
    const HostSession* hs = sim->session(0);
    const ClientState* cs = sim->client(0);
    // Idle: the last frame published nothing and nothing is pending now (a batch may have
    // arrived after that frame).
    const bool idle_frame = !log.frames.empty() && log.frames.back().pending == 0 &&
                            log.frames.back().publish.slot_writes() == 0 && cs->desired().pending_count() == 0;
    if (hs->last_batch_id() > batch0 && cs->last_batch_id() == hs->last_batch_id() && idle_frame) break;
    if (sim->now() > t0 + 30.0) return json{{"error", "teleport did not converge within 30 s"}};
  }
  if (Status s = sim->check_converged(); !s) return json{{"error", s.message()}};
  double conv_t = t0;
  std::size_t last_busy = 0;
  for (std::size_t i = 0; i < log.frames.size(); ++i)
    if (log.frames[i].pending > 0 || log.frames[i].publish.slot_writes() > 0) last_busy = i;
  if (last_busy + 1 < log.frames.size()) conv_t = log.frames[last_busy + 1].t;
  const double conv_s = conv_t - t0;
  // Writes and ranges per frame while converging.
  double writes = 0, ranges = 0, edits = 0;
  std::size_t busy_frames = 0;
  std::uint32_t max_writes = 0;
  double max_cost = 0.0;
  for (std::size_t i = 0; i <= last_busy && i < log.frames.size(); ++i) {
    const auto& f = log.frames[i];
    if (f.publish.slot_writes() == 0) continue;
    ++busy_frames;
    writes += f.publish.slot_writes();
    edits += f.publish.edits();
    ranges += static_cast<double>(f.ranges);
    max_writes = std::max(max_writes, f.publish.slot_writes());
    max_cost = std::max(max_cost, f.cost_s);
  }
  const std::uint64_t teleport_bytes = sim->down_link(0).stats().wire_bytes - bytes_before;
  const std::size_t desired = sim->client(0)->desired().desired_count();
  // Flicker window: static scene, head sway around B.
  log.frames.clear();
  auto published_ids = [&sim]() {
    std::vector<std::uint64_t> ids;
    for (GaussianId id : sim->client(0)->slots().occupants()) ids.push_back(to_underlying(id));
    std::sort(ids.begin(), ids.end());
    return ids;
  };
  const std::vector<std::uint64_t> before_ids = published_ids();
  // A standing user's sway: 5 cm at 0.3 Hz sideways, 3 cm at 0.45 Hz forward, 3 deg of
  // yaw at 0.2 Hz, sampled at the 10 Hz pose rate.
  const double w0 = sim->now();
  for (int k = 1; k <= 60; ++k) {
    const double tt = 0.1 * k, two_pi = 6.283185307;
    const glm::vec3 p = b_pos + glm::vec3(0.03f * static_cast<float>(std::sin(two_pi * 0.45 * tt)), 0.0f,
                                          0.05f * static_cast<float>(std::sin(two_pi * 0.3 * tt)));
    sim->set_pose(0, p, yaw(b_yaw + 3.0 * 3.14159265 / 180.0 * std::sin(two_pi * 0.2 * tt)));
    if (Status s = sim->run_until(w0 + tt); !s) return json{{"error", s.message()}};
  }
  std::uint64_t membership_changes = 0;
  for (const auto& f : log.frames) membership_changes += f.publish.inserted + f.publish.removed + 2ull * f.publish.replaced;
  const std::vector<std::uint64_t> after_ids = published_ids();
  std::vector<std::uint64_t> net;
  std::set_symmetric_difference(before_ids.begin(), before_ids.end(), after_ids.begin(), after_ids.end(), std::back_inserter(net));
  // Churn: every membership change; flicker: the changes that were undone within the
  // window (an id that left and came back, or came and left again).
  const double window = sim->now() - w0;
  const double churn_per_s = static_cast<double>(membership_changes) / window;
  const double flicker_per_s = static_cast<double>(membership_changes - std::min<std::uint64_t>(membership_changes, net.size())) / window;
  const double wall_s = seconds_since(wall0);
  std::printf("   %-12s %9.3f %12zu %10.1f %10.1f %9u %9.2f %11.2f %9.1f %10.1f %8.1f\n", name, conv_s, desired,
              busy_frames ? writes / static_cast<double>(busy_frames) : 0.0,
              busy_frames ? ranges / static_cast<double>(busy_frames) : 0.0, max_writes, max_cost * 1e3,
              static_cast<double>(teleport_bytes) / 1e6, churn_per_s, flicker_per_s, wall_s);
  return json{{"mode", name},
              {"convergence_s", conv_s},
              {"desired", desired},
              {"busy_frames", busy_frames},
              {"slot_writes_per_busy_frame", busy_frames ? writes / static_cast<double>(busy_frames) : 0.0},
              {"edits_per_busy_frame", busy_frames ? edits / static_cast<double>(busy_frames) : 0.0},
              {"upload_ranges_per_busy_frame", busy_frames ? ranges / static_cast<double>(busy_frames) : 0.0},
              {"max_slot_writes_per_frame", max_writes},
              {"max_modelled_frame_ms", max_cost * 1e3},
              {"teleport_wire_bytes", teleport_bytes},
              {"churn_membership_changes_per_s", churn_per_s},
              {"flicker_undone_changes_per_s", flicker_per_s},
              {"flicker_window_s", sim->now() - w0},
              {"wall_s", wall_s}};
}

// ---- 4. steady state ---------------------------------------------------------------

json bench_steady(const StreamBenchOptions& o) {
  auto sim = Simulation::create(base_config(o, PublishMode::Progressive, true));
  if (!sim) return json{{"error", sim.message()}};
  const Aabb b = sim->scene().bounds();
  sim->set_pose(0, glm::vec3(0.5f * (b.min.x + b.max.x), 1.6f, 0.5f * (b.min.z + b.max.z)), yaw(0.0));
  // Skip the initial fill; measure while the scene keeps evolving (epochs at 10 Hz).
  if (Status s = sim->run_until(1.5); !s) return json{{"error", s.message()}};
  const std::uint64_t b0 = sim->down_link(0).stats().wire_bytes, p0 = sim->down_link(0).stats().bytes;
  const double t0 = sim->now();
  std::uint64_t writes = 0, ranges = 0, frames = 0;
  sim->on_frame([&](const FrameSample& f) {
    writes += f.publish.slot_writes();
    ranges += f.ranges;
    ++frames;
  });
  if (Status s = sim->run_until(3.5); !s) return json{{"error", s.message()}};
  const double dt = sim->now() - t0;
  const double wire_bps = static_cast<double>(sim->down_link(0).stats().wire_bytes - b0) / dt;
  const double payload_bps = static_cast<double>(sim->down_link(0).stats().bytes - p0) / dt;
  std::printf("\n4. steady state (scene evolving at 10 epochs/s, viewer still, M = %u, %.1f s window)\n", o.budget, dt);
  std::printf("   wire bytes/s %.3g (messages %.3g B/s), slot writes/frame %.1f, upload ranges/frame %.1f\n", wire_bps,
              payload_bps, frames ? static_cast<double>(writes) / frames : 0.0, frames ? static_cast<double>(ranges) / frames : 0.0);
  return json{{"window_s", dt},
              {"wire_bytes_per_s", wire_bps},
              {"message_bytes_per_s", payload_bps},
              {"slot_writes_per_frame", frames ? static_cast<double>(writes) / frames : 0.0},
              {"upload_ranges_per_frame", frames ? static_cast<double>(ranges) / frames : 0.0}};
}

// ---- 5. sealed stream -----------------------------------------------------------------

// Seal and open throughput (MB/s of frame bytes, thread CPU, median of 5 rounds) per
// frame size, and the CPU a sealed teleport of `teleport_bytes` costs each end.
json bench_sealed(std::uint64_t teleport_bytes) {
  std::printf("\n5. sealed stream (XChaCha20-Poly1305 per frame, one core, thread CPU, median of 5)\n");
  std::printf("   %-10s %10s %10s %14s\n", "frame", "seal MB/s", "open MB/s", "bytes added");
  json rows = json::array();
  if (!net::auth_init()) return json{{"error", "libsodium could not be initialised"}};
  net::StreamKey key{};  // the cipher's cost does not depend on where the key came from
  key.fill(7);
  net::StreamCipher sealer(key, net::StreamDirection::HostToClient);
  net::StreamCipher opener(key, net::StreamDirection::HostToClient);
  std::mt19937 rng(3);
  double seal_large = 0.0, open_large = 0.0;
  for (std::size_t bytes : {std::size_t{64}, std::size_t{4} << 10, std::size_t{256} << 10, std::size_t{16} << 20}) {
    std::vector<std::uint8_t> frame(bytes);
    for (auto& b : frame) b = static_cast<std::uint8_t>(rng());
    // Enough frames per round for ~64 MiB, at least 8.
    const std::size_t count = std::max<std::size_t>(8, (std::size_t{64} << 20) / bytes);
    std::vector<double> seal_mbs, open_mbs;
    for (int round = 0; round < 5; ++round) {
      std::vector<std::vector<std::uint8_t>> packets;
      packets.reserve(count);
      double t0 = thread_cpu_s();
      for (std::size_t k = 0; k < count; ++k) packets.push_back(sealer.seal(frame));
      const double seal_s = thread_cpu_s() - t0;
      t0 = thread_cpu_s();
      for (const auto& p : packets)
        if (!opener.open(p)) return json{{"error", "a sealed frame did not open"}};
      const double open_s = thread_cpu_s() - t0;
      const double mb = static_cast<double>(bytes * count) / 1e6;
      seal_mbs.push_back(mb / std::max(seal_s, 1e-9));
      open_mbs.push_back(mb / std::max(open_s, 1e-9));
    }
    const double seal_med = apps::percentile(seal_mbs, 0.5), open_med = apps::percentile(open_mbs, 0.5);
    seal_large = seal_med;
    open_large = open_med;
    const std::size_t added = net::kSealedHeaderBytes + net::kSealedTagBytes;
    std::printf("   %-10zu %10.0f %10.0f %9zu (%4.1f %%)\n", bytes, seal_med, open_med, added,
                100.0 * static_cast<double>(added) / static_cast<double>(bytes));
    rows.push_back(json{{"frame_bytes", bytes},
                        {"seal_mb_per_s", seal_med},
                        {"open_mb_per_s", open_med},
                        {"seal_mb_per_s_runs", seal_mbs},
                        {"open_mb_per_s_runs", open_mbs},
                        {"bytes_added", added}});
  }
  json out{{"frames", rows}};
  if (teleport_bytes > 0) {
    const double mb = static_cast<double>(teleport_bytes) / 1e6;
    const double host_ms = 1e3 * mb / std::max(seal_large, 1e-9), client_ms = 1e3 * mb / std::max(open_large, 1e-9);
    std::printf("   the progressive teleport above (%.1f MB): + %.1f ms host CPU to seal, + %.1f ms client CPU to open\n",
                mb, host_ms, client_ms);
    out["teleport"] = json{{"wire_bytes", teleport_bytes}, {"seal_cpu_ms", host_ms}, {"open_cpu_ms", client_ms}};
  }
  return out;
}

int bench_stream(const StreamBenchOptions& o) {
  json out;
  out["coalescing"] = bench_coalescing(o);
  if (o.teleport) {
    std::printf("\n2+3. far teleport: M = %u of a %zu-Gaussian synthetic room, link %.0f Mbit/s %.1f ms, display %.0f Hz\n",
                o.budget, o.scene_gaussians, o.bandwidth_bps / 1e6, o.latency_s * 1e3, o.display_hz);
    std::printf("   (virtual time; convergence target <= 0.5 s, paper 0.87-1.63 s; flicker target 0)\n");
    std::printf("   %-12s %9s %12s %10s %10s %9s %9s %11s %9s %10s %8s\n", "mode", "conv s", "desired", "writes/fr", "ranges/fr",
                "max wr/fr", "max fr ms", "teleport MB", "churn/s", "flicker/s", "wall s");
    out["teleport"] = json::array({bench_teleport(o, PublishMode::Immediate), bench_teleport(o, PublishMode::Progressive)});
    if (o.calibrated) {
      StreamBenchOptions c = o;
      c.cost = *o.calibrated;
      c.cost_label = "cal";
      std::printf("   with the calibrated frame cost (/cal): %.2f ms + %.4f us/write + %.2f us/range\n",
                  c.cost.base_s * 1e3, c.cost.per_write_s * 1e6, c.cost.per_range_s * 1e6);
      out["teleport_calibrated"] = json{{"base_ms", c.cost.base_s * 1e3},
                                        {"per_write_us", c.cost.per_write_s * 1e6},
                                        {"per_range_us", c.cost.per_range_s * 1e6},
                                        {"runs", json::array({bench_teleport(c, PublishMode::Immediate),
                                                              bench_teleport(c, PublishMode::Progressive)})}};
    }
  }
  if (o.steady) out["steady_state"] = bench_steady(o);
  if (o.sealed) {
    std::uint64_t teleport_bytes = 0;
    if (out.contains("teleport"))
      for (const json& t : out["teleport"])
        if (t.contains("teleport_wire_bytes")) teleport_bytes = t["teleport_wire_bytes"].get<std::uint64_t>();
    out["sealed"] = bench_sealed(teleport_bytes);
  }
  out["definitions"] = {
      {"convergence", "teleport to the first frame from which published == desired (final), end state checked by checksum"},
      {"churn", "published-set membership changes per second in a 6 s window after convergence, static scene, head sway 5 cm / 3 cm / 3 deg"},
      {"flicker", "churn undone within the window (id left and came back, or came and left): changes - |start XOR end|, per second"},
      {"time", "virtual simulation time; frame cost from sim::FrameCostModel"}};
  if (!o.json_out.empty()) {
    if (!write_json(o.json_out, out, "stream")) return 1;
  }
  return 0;
}

BenchRun bench_stream_setup(CLI::App& cmd) {
  using gauss::apps::at_least;
  using gauss::apps::in_range;
  auto o = std::make_shared<StreamBenchOptions>();
  cmd.add_option("--budget", o->budget, "M: the client's budget")->check(in_range(1u, kMaxSlotCapacity))->type_name("M");
  cmd.add_option("--scene", o->scene_gaussians, "Gaussians of the synthetic room")
      ->check(at_least<std::size_t>(1))
      ->type_name("N");
  cmd.add_option("--coalesce-ids", o->coalesce_ids, "distinct ids of the coalescing benchmark")
      ->check(in_range<std::size_t>(1, kMaxSlotCapacity))
      ->type_name("N");
  cmd.add_option_function<double>("--mbit", [o](double v) { o->bandwidth_bps = v * 1e6; }, "link bandwidth, Mbit/s")
      ->check(at_least(0.001))
      ->default_str(CLI::detail::to_string(o->bandwidth_bps / 1e6))
      ->type_name("B");
  cmd.add_option_function<double>("--latency-ms", [o](double v) { o->latency_s = v * 1e-3; }, "link latency, ms")
      ->check(at_least(0.0))
      ->default_str(CLI::detail::to_string(o->latency_s * 1e3))
      ->type_name("L");
  cmd.add_option("--hz", o->display_hz, "display rate")->check(in_range(1.0, 1000.0))->type_name("H");
  cmd.add_option("--json", o->json_out, "write the results as JSON")->type_name("FILE");
  cmd.add_option_function<std::string>(
         "--frame-cost",
         [o](const std::string& v) {
           double base_ms = 0, write_us = 0, range_us = 0;
           if (std::sscanf(v.c_str(), "%lf,%lf,%lf", &base_ms, &write_us, &range_us) != 3 || !(base_ms > 0) ||
               !(write_us >= 0) || !(range_us >= 0))
             throw CLI::ValidationError("--frame-cost", "expected BASE_MS,WRITE_US,RANGE_US (base > 0, others >= 0)");
           o->calibrated = FrameCostModel{base_ms * 1e-3, write_us * 1e-6, range_us * 1e-6};
         },
         "also run the teleport with this frame cost (gauss-bench client's calibration), beside the default")
      ->type_name("MS,US,US");
  cmd.add_flag_callback("--no-teleport", [o] { o->teleport = false; }, "skip the far-teleport part (2+3)");
  cmd.add_flag_callback("--no-steady", [o] { o->steady = false; }, "skip the steady-state part (4)");
  cmd.add_flag_callback("--no-sealed", [o] { o->sealed = false; }, "skip the sealed-stream cost (5)");
  cmd.add_option("--pose-smoothing", o->pose_smoothing_s,
                 "the host's sway low-pass time constant in s (0 = re-select at the raw pose; default: the "
                 "session's own)")
      ->check(at_least(0.0))
      ->default_str("session default")
      ->type_name("S");
  return [o] { return bench_stream(*o); };
}

}  // namespace

GAUSS_BENCH("stream", "streaming policy: coalescing edits/s, teleport convergence + flicker per mode, ranges/frame, wire bytes/s",
            bench_stream_setup);
