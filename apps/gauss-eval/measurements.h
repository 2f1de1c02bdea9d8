#pragma once
// The measurements of one room, each returning its part of report.json (deterministic:
// virtual times, counts and metrics only) and writing its PNGs through the PanelWriter.
// Wall-clock figures go to Room::timing (report.json's "timing", left out by --no-timing).
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "eval_scene.h"
#include "eval_session.h"
#include "measure.h"
#include "options.h"
#include "panels.h"

namespace gauss::eval_app {

// Progress for the status line ("fidelity camera 2/3").
using Progress = std::function<void(const std::string&)>;

// Wall-clock figures of the room's runs.
struct Timing {
  std::vector<double> frame_cpu_ms;  // the client's display thread, per frame
  std::vector<double> frame_gpu_ms;  // the client's GPU passes, per frame (all views)
  std::map<std::string, std::vector<double>> pass_gpu_ms;  // per pass, per frame (all views)
  Json phases = Json::object();      // seconds per phase

  // Adds the client's finished frames' GPU figures.
  void add_gpu(const std::vector<client::GpuFrameStats>& frames);
};

// What every measurement of a room works with.
struct Room {
  vk::Context& context;
  const Options& options;
  const EvalScene& scene;
  render::SplatRenderer& full;  // the host's render of the full float scene (PC)
  const PanelWriter& panels;
  Timing& timing;
  Progress progress;
};

// A fresh connection (host session + client) at budget M and its sent-set renderer.
struct Stream {
  std::unique_ptr<EvalSession> session;
  std::unique_ptr<render::SplatRenderer> sent;
};
// publication_thread: EvalSessionConfig::publication_thread (lock step). lod: the host's
// level of detail, else the options' (--lod on or both).
Expected<Stream> open_stream(Room& room, std::uint32_t budget, PublishMode mode, bool publication_thread = false,
                             std::optional<bool> lod = std::nullopt);
// The session settings the options give, at budget M and publication mode.
EvalSessionConfig session_config(const Options& options, std::uint32_t budget, PublishMode mode);

// Settles and captures (capture_client) and adds the frame times to room.timing.
Expected<ClientCapture> capture(Room& room, Stream& stream, const Camera& camera,
                                const std::function<void(const client::DisplayFrameStats&)>& on_frame = {});

// The fidelity chain at each of the room's cameras: GT -> PC -> HS, and HS against the
// host's render of the set it sent, at M = --budget. Panels <room>_cam<k>.png:
// GT | PC | HS | FLIP(PC, HS).
Expected<Json> measure_fidelity(Room& room);

// GT-PC, GT-HS and PC-HS (each over its pixels, see definitions) and the coverage
// fractions of the client's frame `hs` at `cam`, whose coverage is `hs_cover` (the sent
// set's), added to `out`; the panel `panel`.png (GT | PC | HS | FLIP(PC, HS)) written
// unless `panel` is empty. PC-HS twice: over the pixels both cover ("pc_hs", the paper's
// content intersection, blind to holes) and over every pixel PC covers ("pc_hs_all": a hole
// in HS counts as an error).
// Errors: the host's full render, the FLIP map, the panel.
Status add_fidelity_chain(Room& room, const Camera& cam, const ImageRGBA8& hs, const eval::Mask& hs_cover,
                          const std::string& panel, Json& out);

// A query of the semantic table: the class query, and the instance query (--instance-id,
// else the first object labelled --instance-label).
struct QuerySpec {
  std::string kind;  // "class" | "instance"
  std::string name;  // "chair", "robot_arm #8"
  SemanticQuery query;
  msg::Query wire;
  std::string error;  // not measurable (no such object): the row says why
};
std::vector<QuerySpec> query_specs(const SceneStore& store, const Options& options);
// A query's connection budget M (--semantic-budget, else |G_obj|, at least 16), its
// reserve floor(rho M), and the target residency it must reach: min(|G_obj|, reserve).
struct QueryBudget {
  std::uint32_t m{0};
  std::uint64_t reserve{0};
  std::uint64_t expected{0};
};
QueryBudget query_budget(const Options& options, std::size_t object_gaussians);
// The host's render of the targets' appearance Gaussians alone (a scene file's object
// pixels: those it covers). Errors: the renderer.
Expected<std::unique_ptr<render::SplatRenderer>> target_renderer(Room& room, std::span<const ObjectId> targets);

// The semantic reallocation table for the class query and the instance query, each on
// its own connection at its own M (--semantic-budget): resident Gaussians on the target
// with and without the query at a near and a far view, share against
// min(|G_obj|, floor(rho M)) / M, object-region metrics. Panels <room>_<kind>_<view>.png:
// GT | HS without | FLIP(GT, without) | HS with | FLIP(GT, with) (FLIP over the object).
Expected<Json> measure_semantic(Room& room);

// Teleport far and return, per publication mode (progressive, immediate), each on its own
// connection at M = --budget: time until published == desired, SSIM convergence to the
// settled frame, post-convergence flicker and churn under head sway. See temporal.cpp.
Expected<Json> measure_temporal(Room& room);

// The far teleport target of camera `a`, with a's intrinsics: in a room, its eye mirrored
// through the room centre (x and z, kept 25 cm inside the walls), looking the opposite
// way; around a scene file, its eye mirrored across the vertical axis through the centre
// at 0.4 of its distance, looking at the centre (a close-up of the far side).
Camera teleport_target(const Camera& a, const EvalScene& scene);

// Frame timing while publication runs, the headset's case: stereo at --ipd, M =
// --stereo-budget, progressive; idle at A, a far teleport streaming in, idle at B. Returns
// the deterministic part (frames, convergence, resident); `timing` gets the wall-clock
// percentiles per phase (CPU ms per frame, GPU ms per frame and per pass). See
// frame_timing.cpp.
Expected<Json> measure_stereo_timing(Room& room, Json& timing);

// Stage latencies of model edits: the room produced live (half its epochs before the
// client connects, then one per --epoch-period) at M = --budget; per epoch, virtual
// seconds from available (committed to the host's scene) to sent, received, published and
// the first frame rendered with it. See latency.cpp.
Expected<Json> measure_model_latency(Room& room);
// A query's stage latencies from the event logs, virtual seconds after `sent_at` (when the
// client issued it): resolved (host), highlight, first additional target content,
// converged (client); and the initial / desired target residency.
Json query_latency(EvalSession& session, std::uint32_t query_id, double sent_at);

// gauss-eval --realtime: gauss-host started as a child process serving this scene,
// the real client over loopback ENet on the wall clock: per fidelity camera a fresh
// connection settled, captured and compared (GT -> PC -> HS, and HS against the host's
// render of the set its dump says it sent); a teleport far and back per publication mode.
// Wall-clock figures; nothing reproduces. See realtime.cpp.
Expected<Json> measure_realtime(Room& room);

// The budget ablation over --ablation (M) and --ablation-sizes: per point the means over
// the fidelity cameras of PC-HS (and GT-HS) metrics at M, each on a fresh connection. The
// client's GPU frame time p50 / p95 of idle frames at each point (wall clock) is appended
// to `frame_ms_p50` / `frame_ms_p95`, in the order of the returned points.
Expected<Json> measure_ablation(Room& room, std::vector<double>& frame_ms_p50, std::vector<double>& frame_ms_p95);

}  // namespace gauss::eval_app
