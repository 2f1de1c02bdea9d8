// gauss-eval --realtime: the evaluation against the real programs' paths, on the wall clock.
//
// Per scene, gauss-host runs as a child process (host_process.h) serving the very scene
// this process holds for GT and PC: synthetic:V with the same seed, Gaussian count and
// epochs, its epochs produced back to back (--epoch-period 0) and no fused surface
// (--surface-voxel 0, as --surface none here), after which the synthetic trajectory is
// exhausted and the host's scene no longer changes; or the same scene file with the same
// labels and objects. gauss-eval waits for the host's status line that says so and checks
// the final epoch (and a file's Gaussian count) against its own copy; the host's dump
// then proves it, record by record (sent_matches_scene).
//
// HS against the host's render of the set it sent: the host writes that set (--dump-sent)
// only when the client's session ends, so every measured view is its own connection:
// connect, settle, capture the frame and the published set (slot order, checksum),
// disconnect, wait for the dump, load it in the client's slot order and render it. The
// fidelity cameras therefore each converge from an empty client (a fresh connection at
// the camera), unlike the deterministic run, which moves one connection from camera to
// camera. The teleport (A, far B, back to A) per publication mode is one connection,
// compared the same way after the return. Each query of the semantic table (unless
// --no-semantic) is one connection at M = |G_obj| at the query's near view, the query sent
// as it connects; the "without the query" baseline and the far view are left out.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <optional>
#include <span>
#include <unordered_map>

#include "gauss/engine/lod_hierarchy.h"
#include "gauss/engine/ply_gaussian.h"
#include "gauss/engine/ply_mesh.h"
#include "gauss/engine/scene_up.h"
#include "gauss/engine/slot_table.h"
#include "host_process.h"
#include "measurements.h"
#include "realtime_client.h"
#include "seconds_since.h"

namespace gauss::eval_app {

namespace {

namespace fs = std::filesystem;

// Bounds of the waits on the host process, wall seconds. Start: it commits its first
// epoch (a scene file: reads it whole) before it listens and says its port.
constexpr double kHostStartTimeout_s = 120.0;
// Its scene complete: the remaining synthetic epochs back to back, then its status line
// (once a second) says "(final)".
constexpr double kHostSceneTimeout_s = 300.0;
// A dump after the client left: the host sees the ENet disconnect within milliseconds and
// writes at most M Gaussians.
constexpr double kDumpTimeout_s = 30.0;

const char* mode_name(PublishMode m) { return m == PublishMode::Progressive ? "progressive" : "immediate"; }

// The gauss-host beside this executable, unless --host-exe names one.
fs::path host_executable(const Options& o) {
  if (!o.host_exe.empty()) return o.host_exe;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  return (ec ? fs::path("gauss-host") : self.parent_path() / "gauss-host");
}

// The host's command line for `scene`: the same scene, rho, a free loopback port (0: it
// reports the one it bound), its dumps into `dump_dir`. Not --quiet: its status line
// says when the scene is final.
std::vector<std::string> host_args(const Options& o, const EvalScene& scene, const fs::path& dump_dir) {
  std::vector<std::string> a{"--bind",     "127.0.0.1:0",     "--rho", shortest(o.rho),
                             "--dump-sent", dump_dir.string(), "--lod", o.lod_on() ? "on" : "off"};
  if (scene.synthetic) {
    a.insert(a.end(), {"--scene", "synthetic:" + std::to_string(scene.variant), "--seed", std::to_string(o.seed),
                       "--gaussians", std::to_string(o.gaussians), "--epochs", std::to_string(o.epochs),
                       "--epoch-period", "0", "--surface-voxel", "0"});
    return a;
  }
  a.insert(a.end(), {"--scene", o.scene_file.string()});
  if (scene.capture)  // every frame at once, seeded and fused as this evaluation's copy
    a.insert(a.end(), {"--epoch-period", "0", "--rgbd-stride", std::to_string(o.rgbd_stride), "--surface-voxel",
                       o.surface == "fused" ? shortest(kCaptureSurfaceVoxel) : std::string("0")});
  else if (o.up)  // the up it announces is the one these cameras stand upright for
    a.insert(a.end(), {"--up", up_label(*o.up)});
  if (!o.labels.empty()) a.insert(a.end(), {"--labels", o.labels.string()});
  if (!o.objects.empty()) a.insert(a.end(), {"--objects", o.objects.string()});
  return a;
}

// Starts the host for the room's scene and waits until its scene is final and the same
// as ours (final epoch; a file's Gaussian count). Fills `host_json`.
Expected<std::unique_ptr<HostProcess>> start_host(Room& room, const fs::path& dir, Json& host_json) {
  const EvalScene& scene = room.scene;
  const fs::path exe = host_executable(room.options);
  room.progress("starting gauss-host");
  auto host = HostProcess::start(exe, host_args(room.options, scene, dir / "sent"), dir / "host.log",
                                 kHostStartTimeout_s);
  if (!host) return host.error();
  room.progress("gauss-host (pid " + std::to_string((*host)->pid()) + ", port " + std::to_string((*host)->port()) +
                ") producing its scene");
  auto final_epoch = (*host)->wait_final_epoch(kHostSceneTimeout_s);
  if (!final_epoch) return final_epoch.error();
  const std::uint64_t ours = to_underlying(scene.store->epoch());
  if (*final_epoch != ours)
    return Error{"gauss-host's scene ended at epoch " + std::to_string(*final_epoch) + ", this evaluation's copy at " +
                 std::to_string(ours) + ": not the same scene (see " + (*host)->log().string() + ")"};
  if (!scene.synthetic && !scene.capture && (*host)->first_epoch_gaussians() != scene.store->size())
    return Error{"gauss-host serves " + std::to_string((*host)->first_epoch_gaussians()) + " Gaussians of " +
                 scene.source + ", this evaluation reads " + std::to_string(scene.store->size())};
  host_json = Json{{"executable", exe.string()},
                   {"arguments", host_args(room.options, scene, dir / "sent")},
                   {"pid", (*host)->pid()},
                   {"port", (*host)->port()},
                   {"log", (*host)->log().string()},
                   {"final_epoch", *final_epoch}};
  return host;
}

// HS against the host's render of the set it sent (its dump), and what the dump proves.
struct SentComparison {
  fs::path dump;
  CoveredImage sent;
  std::uint64_t differing{0};
  std::uint64_t gaussians{0};
  bool published_equals_sent{false};  // the client's published checksum = the dump's
  bool matches_scene{false};          // each sent Gaussian = our scene's, quantised; a surface iff ours has one
  std::uint64_t interior{0};          // LoD records among them (the host's hierarchy's: not compared)
};

// Checksums of the dump (as the client decodes the records) and of our scene's Gaussians
// of the same ids, quantised with our codec.
void compare_records(const EvalScene& scene, const GaussianCloud& dump, bool dump_has_mesh,
                     const RealtimeCapture& cap, SentComparison& out) {
  std::uint64_t dump_sum = 0, scene_sum = 0;
  bool all_ours = true;
  for (const Gaussian& g : dump.gaussians) {
    dump_sum += record_hash(g.id, g);
    if (is_lod_interior_id(g.id)) {  // a LoD record of the host's own hierarchy: not the scene's
      ++out.interior;
      scene_sum += record_hash(g.id, g);
      continue;
    }
    if (const Gaussian* ours = scene.store->find(g.id))
      scene_sum += record_hash(g.id, quantize_roundtrip(*ours, scene.codec));
    else
      all_ours = false;
  }
  out.gaussians = dump.gaussians.size();
  out.published_equals_sent = cap.slots.size() == dump.gaussians.size() && dump_sum == cap.published_checksum;
  out.matches_scene = all_ours && scene_sum == dump_sum && dump_has_mesh == !scene.store->surface_chunks().empty();
}

Expected<SentComparison> compare_with_dump(Room& room, const fs::path& ply, std::uint32_t budget,
                                           const RealtimeCapture& cap, const Camera& cam) {
  SentComparison out;
  out.dump = ply;
  auto dump = read_gaussian_ply(ply);
  if (!dump) return Error{"the host's dump: " + dump.message()};
  if (!dump->report.has_gaussian_id) return Error{"the host's dump " + ply.string() + " has no gaussian_id"};
  const fs::path mesh_path = ply.parent_path() / (ply.stem().string() + ".mesh.ply");
  std::error_code ec;
  const bool has_mesh = fs::exists(mesh_path, ec);
  compare_records(room.scene, dump->cloud, has_mesh, cap, out);

  auto renderer = render::SplatRenderer::create(room.context, {.capacity = budget,
                                                               .sh_degree = dump->cloud.sh_degree,
                                                               .max_width = cam.width,
                                                               .max_height = cam.height});
  if (!renderer) return Error{"the renderer of the host's dump: " + renderer.message()};
  std::unordered_map<std::uint64_t, std::size_t> index;
  for (std::size_t i = 0; i < dump->cloud.gaussians.size(); ++i) index[to_underlying(dump->cloud.gaussians[i].id)] = i;
  auto record_of = [&](GaussianId id) -> Expected<Gaussian> {
    const auto it = index.find(to_underlying(id));
    if (it == index.end())
      return Error{"the client holds Gaussian " + std::to_string(to_underlying(id)) + ", which the host's dump " +
                   ply.string() + " does not"};
    return dump->cloud.gaussians[it->second];
  };
  if (auto st = write_at_slots(**renderer, cap.slots, record_of); !st) return st.error();
  if (has_mesh) {
    auto mesh = read_mesh_ply(mesh_path);
    if (!mesh) return Error{"the host's dump: " + mesh.message()};
    if (auto st = (*renderer)->set_mesh(mesh->mesh); !st) return Error{mesh_path.string() + ": " + st.message()};
  }
  auto sent = render_covered(**renderer, cam);
  if (!sent) return Error{"rendering the host's dump: " + sent.message()};
  out.sent = std::move(*sent);
  out.differing = differing_pixels(cap.hs, out.sent.image);
  return out;
}

// One connection: its client's name (the host's dump file is named after it), publication
// mode, budget M and an optional query, sent once the connection settled at its views (the
// last view is then captured without it and settled again with it).
struct ConnectionSpec {
  std::string name;
  PublishMode mode{PublishMode::Progressive};
  std::uint32_t budget{0};
  std::optional<msg::Query> query;
  double flicker_s{0.0};  // > 0: a flicker window of this many wall seconds after the last settle
};

// A connection settled at each of its views in turn, captured at the last, closed, and
// compared with the host's dump of it.
struct Connection {
  std::vector<RealtimeSettle> legs;
  std::vector<std::vector<double>> leg_gpu_ms;  // GPU ms per frame finished during each leg
  std::optional<RealtimeFlicker> flicker;
  std::optional<RealtimeCapture> before_query;  // the last view settled without the query
  std::optional<RealtimeQueryStages> query_stages;
  RealtimeCapture capture;
  SentComparison sent;
};

std::vector<double> gpu_totals(Room& room, const std::vector<client::GpuFrameStats>& frames) {
  room.timing.add_gpu(frames);
  std::vector<double> ms;
  for (const client::GpuFrameStats& g : frames) ms.push_back(g.total_ms);
  return ms;
}

Expected<Connection> run_connection(Room& room, HostProcess& host, const ConnectionSpec& spec,
                                    std::span<const Camera> views) {
  const Options& o = room.options;
  const Camera& last = views.back();
  auto client = RealtimeClient::connect(room.context, {.port = host.port(),
                                                       .name = spec.name,
                                                       .budget = spec.budget,
                                                       .mode = spec.mode,
                                                       .display_hz = o.display_hz,
                                                       .width = last.width,
                                                       .height = last.height});
  if (!client) return client.error();
  Connection c;
  const auto settle_leg = [&](const Camera& view) -> Status {
    auto s = (*client)->settle(view, o.settle_timeout_s, o.quiet_s);
    if (!s) return s.error();
    room.timing.frame_cpu_ms.insert(room.timing.frame_cpu_ms.end(), s->frame_cpu_ms.begin(), s->frame_cpu_ms.end());
    c.legs.push_back(std::move(*s));
    c.leg_gpu_ms.push_back(gpu_totals(room, (*client)->take_gpu_stats()));
    return Ok{};
  };
  for (const Camera& view : views)
    if (auto st = settle_leg(view); !st) return st.error();
  if (spec.query) {
    // Settled without it first, so its stages start from a still client, as a user's would.
    auto before = (*client)->capture();
    if (!before) return before.error();
    c.before_query = std::move(*before);
    const auto [id, sent_at] = (*client)->send_query(*spec.query);
    if (auto st = (*client)->wait_for_query(last, o.settle_timeout_s); !st) return st.error();
    if (auto st = settle_leg(last); !st) return st.error();
    c.query_stages = (*client)->query_stages(id, sent_at);
  }
  if (spec.flicker_s > 0.0) {
    auto f = (*client)->flicker(last, spec.flicker_s);
    if (!f) return f.error();
    room.timing.frame_cpu_ms.insert(room.timing.frame_cpu_ms.end(), f->frame_cpu_ms.begin(), f->frame_cpu_ms.end());
    gpu_totals(room, (*client)->take_gpu_stats());
    c.flicker = std::move(*f);
    // The window's last frame looked from a swayed eye: settle at the view again, so the
    // captured frame is the view's own (and whatever the sway made the host send is in).
    auto again = (*client)->settle(last, o.settle_timeout_s, o.quiet_s);
    if (!again) return again.error();
    if (!again->converged) return Error{"did not settle again after the flicker window"};
    gpu_totals(room, (*client)->take_gpu_stats());
  }
  auto cap = (*client)->capture();
  if (!cap) return cap.error();
  c.capture = std::move(*cap);
  const std::vector<double> tail = gpu_totals(room, (*client)->take_gpu_stats());
  c.leg_gpu_ms.back().insert(c.leg_gpu_ms.back().end(), tail.begin(), tail.end());
  (*client)->close();
  auto ply = host.wait_dump(spec.name, kDumpTimeout_s);
  if (!ply) return ply.error();
  auto sent = compare_with_dump(room, *ply, spec.budget, c.capture, last);
  if (!sent) return sent.error();
  c.sent = std::move(*sent);
  return c;
}

// A settle as JSON: wall seconds and counts, and the frame times of its frames.
Json settle_json(const RealtimeSettle& s, const std::vector<double>& gpu_ms) {
  return Json{{"converged", s.converged},
              {"converged_s", s.converged_s},
              {"wall_s", s.wall_s},
              {"frames", s.frames},
              {"slot_writes", s.slot_writes},
              {"frame_cpu_ms", percentiles(s.frame_cpu_ms)},
              {"frame_gpu_ms", percentiles(gpu_ms)}};
}

Json sent_json(const Connection& c, const Camera& cam) {
  return Json{{"differing_pixels", c.sent.differing},
              {"pixels", std::uint64_t{cam.width} * cam.height},
              {"sent_gaussians", c.sent.gaussians},
              {"published_equals_sent", c.sent.published_equals_sent},
              {"sent_matches_scene", c.sent.matches_scene},
              {"sent_lod_interior", c.sent.interior},
              {"dump", c.sent.dump.string()}};
}

// Every frame time of a connection: CPU from its settles, GPU per leg.
void add_frames(const Connection& c, std::vector<double>& cpu, std::vector<double>& gpu) {
  for (const RealtimeSettle& s : c.legs) cpu.insert(cpu.end(), s.frame_cpu_ms.begin(), s.frame_cpu_ms.end());
  for (const auto& g : c.leg_gpu_ms) gpu.insert(gpu.end(), g.begin(), g.end());
}

Expected<Json> realtime_fidelity(Room& room, HostProcess& host) {
  const auto t0 = std::chrono::steady_clock::now();
  const EvalScene& scene = room.scene;
  const Options& o = room.options;
  const PublishMode mode = o.progressive ? PublishMode::Progressive : PublishMode::Immediate;
  Json cameras = Json::array();
  std::vector<double> cpu, gpu;
  for (std::size_t k = 0; k < scene.cameras.size(); ++k) {
    const Camera& cam = scene.cameras[k];
    const std::string where = scene.name + " realtime camera " + std::to_string(k);
    room.progress("realtime camera " + std::to_string(k + 1) + "/" + std::to_string(scene.cameras.size()));
    const ConnectionSpec spec{
        .name = "gauss-eval-cam" + std::to_string(k), .mode = mode, .budget = o.budget, .query = std::nullopt};
    auto c = run_connection(room, host, spec, std::span<const Camera>(&cam, 1));
    if (!c) return Error{where + ": " + c.message()};
    add_frames(*c, cpu, gpu);
    Json j;
    j["camera"] = k;
    j["pose"] = camera_json(cam);
    j["settle"] = settle_json(c->legs.front(), c->leg_gpu_ms.front());
    j["resident"] = c->capture.resident;
    j["desired"] = c->capture.desired;
    if (auto st = add_fidelity_chain(room, cam, c->capture.hs, c->sent.sent.cover,
                                     scene.name + "_realtime_cam" + std::to_string(k), j);
        !st)
      return Error{where + ": " + st.message()};
    j["hs_vs_sent"] = sent_json(*c, cam);
    cameras.push_back(std::move(j));
  }
  room.timing.phases["realtime_fidelity_s"] = apps::seconds_since(t0);
  return Json{{"budget", o.budget},
              {"mode", mode_name(mode)},
              {"cameras", std::move(cameras)},
              {"frame_cpu_ms", percentiles(cpu)},
              {"frame_gpu_ms", percentiles(gpu)}};
}

// Teleport far and back per publication mode, one connection each: settle at A (camera 0),
// at B (teleport_target), back at A; wall seconds to convergence per leg; then the flicker
// window at A (--flicker-window wall seconds, the head swaying).
Expected<Json> realtime_teleport(Room& room, HostProcess& host) {
  const auto t0 = std::chrono::steady_clock::now();
  const EvalScene& scene = room.scene;
  const Camera a = scene.cameras.front();
  const Camera b = teleport_target(a, scene);
  const Camera path[3] = {a, b, a};
  Json out = Json::array();
  for (PublishMode mode : {PublishMode::Progressive, PublishMode::Immediate}) {
    room.progress(std::string("realtime teleport, ") + mode_name(mode));
    const ConnectionSpec spec{.name = std::string("gauss-eval-teleport-") + mode_name(mode),
                              .mode = mode,
                              .budget = room.options.budget,
                              .query = std::nullopt,
                              .flicker_s = room.options.flicker_window_s};
    auto c = run_connection(room, host, spec, path);
    if (!c) return Error{scene.name + " realtime teleport (" + mode_name(mode) + "): " + c.message()};
    out.push_back(Json{{"mode", mode_name(mode)},
                       {"a", camera_json(a)},
                       {"b", camera_json(b)},
                       {"first", settle_json(c->legs[0], c->leg_gpu_ms[0])},
                       {"teleport", settle_json(c->legs[1], c->leg_gpu_ms[1])},
                       {"return", settle_json(c->legs[2], c->leg_gpu_ms[2])},
                       {"flicker", Json{{"window_s", c->flicker->window_s},
                                        {"frames", c->flicker->frames},
                                        {"mean_abs_change", c->flicker->mean_abs_change},
                                        {"max_abs_change", c->flicker->max_abs_change},
                                        {"slot_writes", c->flicker->slot_writes},
                                        {"membership_changes", c->flicker->membership_changes},
                                        {"host_messages", c->flicker->host_messages},
                                        {"frame_cpu_ms", percentiles(c->flicker->frame_cpu_ms)}}},
                       {"resident", c->capture.resident},
                       {"hs_vs_sent", sent_json(*c, a)}});
  }
  room.timing.phases["realtime_teleport_s"] = apps::seconds_since(t0);
  return out;
}

// A query's client-side stage latencies as JSON (null: a stage not reached).
Json stages_json(const RealtimeQueryStages& q) {
  const auto opt = [](const auto& v) { return v ? Json(*v) : Json(nullptr); };
  return Json{{"targets_s", opt(q.targets_s)},
              {"highlight_s", opt(q.highlight_s)},
              {"first_additional_s", opt(q.first_additional_s)},
              {"converged_s", opt(q.converged_s)},
              {"initial_residency", opt(q.initial_residency)}};
}

// One query of the semantic table on its own connection at its own M (--semantic-budget,
// else |G_obj|), settled at the query's near view without the query, captured, then the
// query sent and settled again: the target's residency must be exactly min(|G_obj|,
// floor(rho M)) (the host's --rho), as in the deterministic table; GT-HS and PC-HS over the
// target's pixels without and with it; the stages on the client's clock; HS against the dump.
Expected<Json> realtime_query(Room& room, HostProcess& host, const QuerySpec& q) {
  const EvalScene& scene = room.scene;
  const Options& o = room.options;
  auto res = resolve_query(q.query, scene.store->objects());
  if (!res) return Json{{"kind", q.kind}, {"query", q.name}, {"error", res.message()}};
  const std::vector<ObjectId> targets = res->ids();
  const auto [m, reserve, expected] = query_budget(o, res->gaussians);
  const Camera near = (scene.synthetic ? object_views(*res, *scene.synthetic, o.width, o.height)
                                       : object_views(*res, scene, o.width, o.height))
                          .near;
  room.progress("realtime query " + q.name);
  auto c = run_connection(room, host,
                          {.name = "gauss-eval-query-" + q.kind,
                           .mode = o.progressive ? PublishMode::Progressive : PublishMode::Immediate,
                           .budget = m,
                           .query = q.wire},
                          std::span<const Camera>(&near, 1));
  if (!c) return c.error();
  const auto on_target = [&](const RealtimeCapture& cap) {
    return static_cast<std::uint64_t>(
        std::count_if(cap.slot_objects.begin(), cap.slot_objects.end(),
                      [&](ObjectId id) { return std::binary_search(targets.begin(), targets.end(), id); }));
  };
  const std::uint64_t on_object = on_target(c->capture);
  // The target's pixels: the ground truth's object ids, else what the targets alone cover.
  const std::optional<GroundTruthImage> gt = ground_truth(scene, near);
  eval::Mask mask;
  if (gt) {
    mask = object_mask(*gt, targets);
  } else {
    auto alone = target_renderer(room, targets);
    if (!alone) return alone.error();
    auto covered = render_covered(**alone, near);
    if (!covered) return covered.error();
    mask = std::move(covered->cover);
  }
  auto pc = render_covered(room.full, near);
  if (!pc) return Error{"the host's full render: " + pc.message()};
  Json ids = Json::array();
  for (ObjectId id : targets) ids.push_back(to_underlying(id));
  return Json{{"kind", q.kind},
              {"query", q.name},
              {"targets", std::move(ids)},
              {"budget", m},
              {"rho", o.rho},
              {"object_gaussians", res->gaussians},
              {"expected_resident", expected},
              {"expected_share", double(expected) / double(m)},
              {"resident_on_object", on_object},
              {"share", double(on_object) / double(m)},
              {"share_matches", on_object == expected},
              {"client_reported_object_gaussians", c->capture.query_target_gaussians},
              {"pose", camera_json(near)},
              {"settle_without_query", settle_json(c->legs.front(), c->leg_gpu_ms.front())},
              {"settle", settle_json(c->legs.back(), c->leg_gpu_ms.back())},
              {"object_pixels", count(mask)},
              {"without_query",
               Json{{"resident_on_object", on_target(*c->before_query)},
                    {"gt_hs_object", gt ? scores(gt->colour, c->before_query->hs, mask) : Json(nullptr)},
                    {"pc_hs_object", scores(pc->image, c->before_query->hs, mask)}}},
              {"gt_hs_object", gt ? scores(gt->colour, c->capture.hs, mask) : Json(nullptr)},
              {"pc_hs_object", scores(pc->image, c->capture.hs, mask)},
              {"latency", stages_json(*c->query_stages)},
              {"hs_vs_sent", sent_json(*c, near)}};
}

Expected<Json> realtime_semantic(Room& room, HostProcess& host) {
  const auto t0 = std::chrono::steady_clock::now();
  Json rows = Json::array();
  for (const QuerySpec& q : query_specs(*room.scene.store, room.options)) {
    if (!q.error.empty()) {
      rows.push_back(Json{{"kind", q.kind}, {"query", q.name}, {"error", q.error}});
      continue;
    }
    auto row = realtime_query(room, host, q);
    if (!row) return Error{room.scene.name + " realtime query " + q.name + ": " + row.message()};
    rows.push_back(std::move(*row));
  }
  room.timing.phases["realtime_semantic_s"] = apps::seconds_since(t0);
  return rows;
}

}  // namespace

Expected<Json> measure_realtime(Room& room) {
  const fs::path dir = room.options.out / "realtime" / room.scene.name;
  std::error_code ec;
  fs::remove_all(dir / "sent", ec);  // a dump from an earlier run must not pass for this one's
  fs::create_directories(dir, ec);
  if (ec) return Error{"cannot create " + dir.string() + ": " + ec.message()};
  Json host_json;
  auto host = start_host(room, dir, host_json);
  if (!host) return Error{room.scene.name + ": " + host.message()};
  auto fidelity = realtime_fidelity(room, **host);
  if (!fidelity) return fidelity.error();
  auto teleport = realtime_teleport(room, **host);
  if (!teleport) return teleport.error();
  Json semantic = Json::array();
  if (room.options.semantic) {
    auto rows = realtime_semantic(room, **host);
    if (!rows) return rows.error();
    semantic = std::move(*rows);
  }
  // gauss-host exits 0 on SIGTERM; anything else is a failure of the host itself.
  auto status = (*host)->stop();
  if (!status) return Error{room.scene.name + ": " + status.message()};
  host_json["exit_status"] = *status;
  if (*status != 0)
    return Error{room.scene.name + ": gauss-host exited with status " + std::to_string(*status) +
                 " when stopped; see " + (dir / "host.log").string()};
  return Json{{"host", std::move(host_json)},
              {"fidelity", std::move(*fidelity)},
              {"teleport", std::move(*teleport)},
              {"semantic", std::move(semantic)}};
}

}  // namespace gauss::eval_app
