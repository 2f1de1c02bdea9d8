// gauss-eval: the paper's evaluation ("System Evaluation") on the real client path,
// deterministic by default. See options.cpp (--help) for what it runs and writes, and
// eval_session.h for how a run reproduces exactly.
//
// Exit status: 0 written and every exactness check held; 1 an error (the message names
// it; no report) or a failed check (the report is written and says which); 2 bad arguments.
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "eval_scene.h"
#include "eval_session.h"
#include "gauss/engine/rgbd_scene.h"
#include "gauss/engine/scene_up.h"
#include "gauss/render/vk_context.h"
#include "status_line.h"
#include "measure.h"
#include "measurements.h"
#include "options.h"
#include "panels.h"
#include "report.h"

namespace {

using namespace gauss;
using namespace gauss::eval_app;
namespace fs = std::filesystem;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// What an RGB-D capture's ground truth is (for the definitions of a run that has one).
const char* const kCaptureTruth =
    "an RGB-D capture's own colour frames at its cameras (their poses and intrinsics), box-filtered to the "
    "evaluation size; pixels whose block lacks depth anywhere are not counted. The capture's Gaussians are seeded "
    "from these same frames (a Gaussian per pixel block, no optimisation), so GT-PC says how well that seeding "
    "reproduces its own input, the ceiling for this scene, not a novel-view score; other views (teleport, object "
    "views, other sizes) have no ground truth";

Json definitions(const Options& o) {
  Json d{
      {"PSNR", "10 log10(255^2 / MSE) over the 8-bit RGB values of the counted pixels; \"inf\" when they are "
               "identical"},
      {"SSIM", "Wang et al. 2004 on Rec. 601 luma, 11x11 Gaussian window (sigma 1.5), mean over the counted pixels"},
      {"FLIP", "LDR FLIP (Andersson et al. 2020, no learned weights): mean per-pixel error in [0, 1] over the "
               "counted pixels, 0 = identical"},
      {"LPIPS", "not computed: it needs learned network weights that this project cannot obtain; FLIP is the "
                "perceptual metric instead"},
      {"GT-referenced pixels", "GT-PC and GT-HS count the pixels with valid ground-truth depth (in the closed "
                               "synthetic rooms: all of them); a scene file has no ground truth: null, n/a in the "
                               "report"},
      {"coverage", "a pixel is covered when the splats' accumulated opacity there is at least 0.5 or a surface is "
                   "drawn under it: rendered over black and over white, the two differ by less than 128 in every "
                   "channel (the blend adds T x background; alpha is always 255)"},
      {"PC-HS pixels", "the pixels both PC and HS cover (the paper's content intersection); the coverage "
                       "fractions say how much each image covers"},
      {"PC-HS over PC's pixels", "the same metrics over every pixel PC covers: where HS shows a hole (black) "
                                 "it counts as an error, which the content intersection hides"},
      {"LoD", "level of detail (--lod): the host keeps a merge hierarchy of the scene (moment-matched parents) "
              "and sends, for what the budget cannot hold in detail, a view-dependent cut of at most M nodes "
              "instead of only its best M Gaussians; a query's reservation stays min(|G_obj|, floor(rho M)) leaves"},
      {"HS vs sent", "HS against the host's render of the set it sent (each Gaussian as the client decodes it, "
                     "loaded in the client's slot order, the scene's surface chunks): RGBA pixels that differ"},
      {"SSIM convergence", "after the return from the teleport: virtual seconds until the first frame from which "
                           "every later frame has SSIM >= 0.99 against the settled (last) frame"},
      {"flicker", "in a window of " + shortest(o.flicker_window_s) + " s after convergence while the head sways "
                  "(5 cm at 0.3 Hz sideways, 3 cm at 0.45 Hz forward, 3 deg yaw at 0.2 Hz; its pose goes to the "
                  "host) the client also renders the return camera held still: the mean absolute change per pixel "
                  "and channel (8-bit levels) between consecutive frames of it; churn = slot writes and published-"
                  "set membership changes in the window"},
      {"query latency", "virtual seconds from the client issuing a query to: the host resolving it; the first "
                        "frame rendered once the client knows the targets (\"highlight\"; gauss-eval draws no tint, "
                        "the event is the same); the first frame with more target Gaussians resident than when the "
                        "query took effect; every desired target Gaussian published"},
      {"model latency", "virtual seconds from a scene epoch's commit on the host to its batch being sent, received, "
                        "published into slots, and first rendered"},
      {"object pixels", "pixels whose ground-truth ray hits one of the query's target objects; without ground "
                        "truth, the pixels the host's render of the targets' Gaussians alone covers"},
      {"convergence", "virtual seconds from the move to a view until the first frame of the final run of frames "
                      "in which nothing was in flight to the client, nothing pending, the published set equal "
                      "to the host's sent set (checksum of the decoded records) and no new host message, held "
                      "for " + shortest(o.quiet_s) + " s"},
      {"clock", "virtual: display frames at " + shortest(o.display_hz) + " Hz, host ticks every 20 ms, "
                "links of " + shortest(o.latency_ms) + " ms latency and " + shortest(o.bandwidth_mbps) +
                " Mbit/s carrying the real encoded messages; progressive publication with a fixed allowance of " +
                std::to_string(o.allowance) + " slot edits per frame"}};
  const bool capture = !o.scene_file.empty() && is_rgbd_capture(o.scene_file);
  if (capture) d["capture ground truth"] = kCaptureTruth;
  if (!o.scene_file.empty() && !capture)
    d["scene file views"] = "cameras on a circle around the centre of the scene's central box (2 %..98 % of the "
                            "positions per axis), 20 deg above its horizon (--up), 1.8 half-diagonals away; object "
                            "views: near = 1.5 target sizes from the target towards camera 0, far = camera 0 moved "
                            "out to 1.5 times its distance; teleport = the far side at 0.4 of camera 0's distance";
  return d;
}

// The deterministic measurements of one scene (the default mode) into `scene_json`; the
// stereo run's wall-clock part into `stereo_timing`, the ablation's plot items appended.
Status measure_deterministic(Room& room, const EvalScene& scene, Json& scene_json, Json& stereo_timing,
                             Json& ablation_items) {
  const Options& o = room.options;
  auto fidelity = measure_fidelity(room);
  if (!fidelity) return fidelity.error();
  scene_json["fidelity"] = std::move(*fidelity);
  if (o.semantic) {
    auto semantic = measure_semantic(room);
    if (!semantic) return semantic.error();
    scene_json["semantic"] = std::move(*semantic);
  }
  if (o.temporal) {
    auto temporal = measure_temporal(room);
    if (!temporal) return temporal.error();
    scene_json["temporal"] = std::move(*temporal);
  }
  // A scene file is one epoch: it has no model edits to time. A snapshot folder has one
  // per snapshot.
  if (o.latency && (scene.synthetic || scene.snapshots >= 2)) {
    auto latency = measure_model_latency(room);
    if (!latency) return latency.error();
    scene_json["model_latency"] = std::move(*latency);
  }
  if (o.stereo_budget) {
    auto stereo = measure_stereo_timing(room, stereo_timing);
    if (!stereo) return Error{scene.name + " stereo timing: " + stereo.message()};
    scene_json["stereo_timing"] = std::move(*stereo);
  }
  if (!o.ablation_budgets.empty()) {
    std::vector<double> p50, p95;
    auto ablation = measure_ablation(room, p50, p95);
    if (!ablation) return ablation.error();
    // The plot script's items: the deterministic means beside the wall-clock frame times.
    for (std::size_t i = 0; i < ablation->size(); ++i) {
      const Json& p = (*ablation)[i];
      ablation_items.push_back(Json{{"scene", scene.name},
                                    {"budget", p["budget"]},
                                    {"lod", p["lod"]},
                                    {"width", p["width"]},
                                    {"height", p["height"]},
                                    {"psnr_pc_hs", p["psnr_pc_hs"]},
                                    {"ssim_pc_hs", p["ssim_pc_hs"]},
                                    {"flip_pc_hs", p["flip_pc_hs"]},
                                    {"frame_ms_p50", p50[i]},
                                    {"frame_ms_p95", p95[i]}});
    }
    scene_json["ablation"] = std::move(*ablation);
  }
  return Ok{};
}

// Every measurement of one scene: synthetic room `variant`, or the scene file (variant
// -1). Fills `scene_json` and `timing_json`.
Status run_scene(vk::Context& ctx, const Options& o, int variant, const PanelWriter& panels, Json& scene_json,
                 Json& timing_json, Json& ablation_items) {
  const auto t0 = std::chrono::steady_clock::now();
  apps::StatusLine status;
  const std::string label =
      "gauss-eval: " + (variant >= 0 ? "room" + std::to_string(variant) : o.scene_file.filename().string()) + ": ";
  status.update(label + (variant >= 0 ? "producing the scene" : "reading the scene"), true);
  auto scene = variant >= 0 ? make_scene(o, variant) : make_file_scene(o);
  if (!scene) return scene.error();
  Timing timing;
  timing.phases["produce_s"] = seconds_since(t0);
  auto full = make_full_renderer(ctx, *scene, o.width, o.height);
  if (!full) return Error{scene->name + ": " + full.message()};
  Room room{ctx, o, *scene, **full, panels, timing, [&](const std::string& what) { status.update(label + what); }};

  scene_json["name"] = scene->name;
  if (variant >= 0) scene_json["variant"] = variant;
  else scene_json["source"] = scene->source;
  if (scene->snapshots > 0) scene_json["snapshots"] = scene->snapshots;
  scene_json["ground_truth"] = scene->synthetic != nullptr || scene->capture;
  if (scene->capture) scene_json["capture_frames"] = scene->capture_frames;
  if (!scene->up_from.empty()) scene_json["up"] = Json{{"axis", up_label(scene->up)}, {"from", scene->up_from}};
  scene_json["gaussians"] = scene->store->size();
  scene_json["appearance_gaussians"] = scene->appearance;
  scene_json["objects"] = scene->store->objects().size();
  scene_json["sh_degree"] = scene->store->sh_degree();
  scene_json["surface_chunks"] = scene->store->surface_chunks().size();
  Json stereo_timing;
  if (o.realtime) {
    auto realtime = measure_realtime(room);
    if (!realtime) return realtime.error();
    scene_json["realtime"] = std::move(*realtime);
  } else if (auto st = measure_deterministic(room, *scene, scene_json, stereo_timing, ablation_items); !st) {
    return st;
  }
  Json pass_json = Json::object();
  for (const auto& [pass, ms] : timing.pass_gpu_ms) pass_json[pass] = percentiles(ms);
  timing_json = Json{{"name", scene->name},
                     {"wall_s", seconds_since(t0)},
                     {"phases", timing.phases},
                     {"frame_cpu_ms", percentiles(timing.frame_cpu_ms)},
                     {"frame_gpu_ms", percentiles(timing.frame_gpu_ms)},
                     {"pass_gpu_ms", pass_json}};
  if (o.stereo_budget) timing_json["stereo_timing"] = std::move(stereo_timing);
  status.done(label + "done in " + std::to_string(static_cast<int>(seconds_since(t0) + 0.5)) + " s");
  return Ok{};
}

// The exactness checks over everything measured.
Json checks_of(const Json& report) {
  bool exact = true, shares = true, converged = true;
  std::uint64_t differing = 0;
  auto settle = [&](const Json& s) { converged = converged && s["converged"].get<bool>(); };
  for (const Json& s : report["scenes"]) {
    for (const Json& c : s["fidelity"]["cameras"]) {
      differing += c["hs_vs_sent"]["differing_pixels"].get<std::uint64_t>();
      settle(c["settle"]);
      if (c.contains("without_lod")) {
        differing += c["without_lod"]["hs_vs_sent"]["differing_pixels"].get<std::uint64_t>();
        settle(c["without_lod"]["settle"]);
      }
    }
    for (const Json& r : s.contains("semantic") ? s["semantic"] : Json::array()) {
      if (r.contains("error")) continue;
      shares = shares && r["share_matches"].get<bool>();
      for (const char* v : {"near", "far"})
        for (const char* w : {"without_query", "with_query"}) {
          differing += r["views"][v][w]["hs_vs_sent_differing"].get<std::uint64_t>();
          settle(r["views"][v][w]["settle"]);
        }
    }
    if (s.contains("temporal"))
      for (const Json& t : s["temporal"])
        for (const char* k : {"first", "teleport", "return"}) settle(t[k]);
    if (s.contains("stereo_timing"))
      for (const char* k : {"settle_a", "teleport"}) settle(s["stereo_timing"][k]);
    if (s.contains("model_latency"))
      for (const char* k : {"settle_first", "settle_last"}) settle(s["model_latency"][k]);
    if (s.contains("ablation"))
      for (const Json& p : s["ablation"])
        for (const Json& c : p["cameras"]) {
          differing += c["hs_vs_sent_differing"].get<std::uint64_t>();
          settle(c["settle"]);
        }
  }
  exact = differing == 0;
  return Json{{"hs_equals_sent_render", exact},
              {"hs_vs_sent_differing_pixels", differing},
              {"semantic_shares_match", shares},
              {"all_converged", converged}};
}

// The checks of a realtime run over every view measured: HS equals the host's render of
// the set its dump says it sent, the client published exactly that set (checksum), the set
// is our scene's (so GT and PC are of the scene the host served), every settle converged.
Json realtime_checks_of(const Json& report) {
  bool converged = true, published = true, same_scene = true, shares = true;
  std::uint64_t differing = 0;
  auto settle = [&](const Json& s) { converged = converged && s["converged"].get<bool>(); };
  auto sent = [&](const Json& h) {
    differing += h["differing_pixels"].get<std::uint64_t>();
    published = published && h["published_equals_sent"].get<bool>();
    same_scene = same_scene && h["sent_matches_scene"].get<bool>();
  };
  for (const Json& s : report["scenes"]) {
    const Json& rt = s["realtime"];
    for (const Json& c : rt["fidelity"]["cameras"]) {
      settle(c["settle"]);
      sent(c["hs_vs_sent"]);
    }
    for (const Json& t : rt["teleport"]) {
      for (const char* k : {"first", "teleport", "return"}) settle(t[k]);
      sent(t["hs_vs_sent"]);
    }
    for (const Json& q : rt["semantic"]) {
      if (q.contains("error")) continue;
      shares = shares && q["share_matches"].get<bool>();
      settle(q["settle_without_query"]);
      settle(q["settle"]);
      sent(q["hs_vs_sent"]);
    }
  }
  return Json{{"hs_equals_sent_render", differing == 0},
              {"hs_vs_sent_differing_pixels", differing},
              {"published_equals_sent", published},
              {"sent_matches_scene", same_scene},
              {"semantic_shares_match", shares},
              {"all_converged", converged}};
}

Json realtime_definitions(const Options& o) {
  Json d{
      {"realtime", "every figure is a wall-clock measurement of real processes on this machine: gauss-host (a child "
                   "process) and the real client (ClientRuntime with its NetClient) over loopback ENet, the client's "
                   "adaptive publication allowance, frames paced at " + shortest(o.display_hz) + " Hz; they do not "
                   "reproduce from run to run"},
      {"PSNR", "10 log10(255^2 / MSE) over the 8-bit RGB values of the counted pixels; \"inf\" when identical"},
      {"SSIM", "Wang et al. 2004 on Rec. 601 luma, 11x11 Gaussian window (sigma 1.5), mean over the counted pixels"},
      {"FLIP", "LDR FLIP (no learned weights): mean per-pixel error in [0, 1] over the counted pixels"},
      {"GT-referenced pixels", "the pixels with valid ground-truth depth; a scene file has none: null (n/a)"},
      {"coverage", "accumulated opacity >= 0.5 or a surface drawn: over black and over white the render differs by "
                   "less than 128 in every channel"},
      {"PC-HS pixels", "the pixels both PC and the host's render of the sent set cover"},
      {"PC-HS over PC's pixels", "the same over every pixel PC covers: a hole in HS counts as an error"},
      {"view", "each fidelity camera is its own connection: the client connects at the camera, settles, is "
               "captured, and disconnects, so gauss-host writes the set it sent (--dump-sent)"},
      {"HS vs sent", "HS against the host's render of its dump (the set it sent, as the client decodes it), loaded "
                     "in the client's slot order: RGBA pixels that differ; published_equals_sent: the checksum of "
                     "the client's published records equals the dump's; sent_matches_scene: the dump's records "
                     "equal this evaluation's scene quantised with its codec (the host served the same scene); LoD records "
                     "(ids with the top bit) are the host's own hierarchy's and are counted, not compared"},
      {"convergence", "wall seconds from the connection (or the move to a view) until the first frame of the final "
                      "run in which the client was welcomed, had nothing pending, published nothing and received "
                      "no host message, held for " + shortest(o.quiet_s) + " s; at most " +
                      shortest(o.settle_timeout_s) + " s"},
      {"teleport", "one connection per publication mode: settle at camera 0 (A), at the far teleport target B, and "
                   "back at A; compared with the host's dump after the return"},
      {"frame times", "CPU: the display thread per frame; GPU: the frame's passes (lavapipe)"},
      {"semantic", "per query one connection at M = " +
                       (o.semantic_budget ? std::to_string(o.semantic_budget) : std::string("|G_obj|")) +
                       " settled at the query's near view without the query and captured, then the query sent "
                       "(the host's rho) and settled again: the target's resident Gaussians against "
                       "min(|G_obj|, floor(rho M)); GT-HS and PC-HS over the target's pixels, without and with"},
      {"query latency", "wall seconds on the client's clock from sending the query to: the host's resolution "
                        "arriving (targets known); the first frame rendered knowing them (\"highlight\"; no tint "
                        "drawn); the first frame with more target Gaussians resident than when the query took "
                        "effect; every desired target Gaussian published. The host's own resolution time is on "
                        "another process's clock and is not compared"},
      {"not measured", "the semantic table's far view, model-edit latencies (the host's commit and the client's "
                       "frame are on two processes' clocks), stereo timing and the budget ablation (deterministic "
                       "runs: gauss-eval without --realtime)"}};
  if (!o.scene_file.empty() && is_rgbd_capture(o.scene_file)) d["capture ground truth"] = kCaptureTruth;
  return d;
}

// Runs the plot script on report.json (its "ablation" list). Returns what it wrote, or why
// not ("skipped: ..."); never fails the run.
Json plot_ablation(const Options& o, const fs::path& json_path) {
  if (o.plot_script.empty() || !fs::exists(o.plot_script)) return "skipped: no plot script";
  if (!fs::exists("/usr/bin/python3")) return "skipped: /usr/bin/python3 is missing";
  const fs::path log = o.out / "plot_eval.log";
  std::error_code ec;
  std::vector<std::string> args{"/usr/bin/python3", o.plot_script, json_path.string(), o.out.string()};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&fa, STDOUT_FILENO, STDERR_FILENO);
  pid_t pid = -1;
  const int spawned = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (spawned != 0) return "skipped: cannot start /usr/bin/python3";
  int status = 0;
  if (waitpid(pid, &status, 0) != pid || !WIFEXITED(status)) return "failed: see plot_eval.log";
  if (WEXITSTATUS(status) == 77) return "skipped: python3-matplotlib is not installed";
  if (WEXITSTATUS(status) != 0) return "failed: see plot_eval.log";
  fs::remove(log, ec);  // kept only when the script failed
  Json files = Json::array();
  for (const auto& e : fs::directory_iterator(o.out, ec)) {
    const std::string f = e.path().filename().string();
    if (f == "pareto.png" || (f.rfind("ablation_", 0) == 0 && e.path().extension() == ".png")) files.push_back(f);
  }
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (auto rc = parse_options(argc, argv, o)) return *rc;
  const auto t0 = std::chrono::steady_clock::now();
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (ec) {
    std::fprintf(stderr, "gauss-eval: cannot create %s: %s\n", o.out.c_str(), ec.message().c_str());
    return 1;
  }
  auto ctx = vk::Context::create({.app_name = "gauss-eval", .device_override = o.device});
  if (!ctx) {
    std::fprintf(stderr, "gauss-eval: no usable Vulkan device: %s\n", ctx.message().c_str());
    return 1;
  }
  const PanelWriter panels(o.out, o.images);
  Json report;
  report["generator"] = "gauss-eval";
  report["name"] = o.name;
  report["command"] = canonical_command(o);
  report["device"] = (*ctx)->device_name();
  if (o.realtime) report["realtime"] = true;
  report["config"] = Json{{"gaussians", o.gaussians},
                          {"epochs", o.epochs},
                          {"seed", o.seed},
                          {"budget", o.budget},
                          {"width", o.width},
                          {"height", o.height},
                          {"cameras", o.cameras},
                          {"rho", o.rho},
                          {"mode", o.progressive ? "progressive" : "immediate"},
                          {"lod", o.lod},
                          {"allowance", o.allowance},
                          {"display_hz", o.display_hz},
                          {"latency_ms", o.latency_ms},
                          {"bandwidth_mbps", o.bandwidth_mbps},
                          {"quiet_s", o.quiet_s},
                          {"surface", o.surface}};
  if (o.realtime) {
    // A realtime run has no modelled link and no fixed allowance.
    for (const char* k : {"allowance", "latency_ms", "bandwidth_mbps"}) report["config"].erase(k);
    report["config"]["settle_timeout_s"] = o.settle_timeout_s;
  }
  report["definitions"] = o.realtime ? realtime_definitions(o) : definitions(o);
  report["scenes"] = Json::array();
  Json timing_scenes = Json::array();
  Json ablation_items = Json::array();
  int rc = 0;
  std::vector<int> scenes = o.variants;
  if (!o.scene_file.empty()) scenes.push_back(-1);
  for (int variant : scenes) {
    Json scene_json, timing_json;
    if (auto st = run_scene(**ctx, o, variant, panels, scene_json, timing_json, ablation_items); !st) {
      std::fprintf(stderr, "gauss-eval: %s\n", st.message().c_str());
      return 1;
    }
    report["scenes"].push_back(std::move(scene_json));
    timing_scenes.push_back(std::move(timing_json));
  }
  report["checks"] = o.realtime ? realtime_checks_of(report) : checks_of(report);
  report["validation_errors"] = (*ctx)->validation_error_count();
  // The plot script's "ablation" list carries frame times (wall clock), so it belongs to
  // the timed report only; the deterministic figures are in each scene's "ablation".
  if (o.timing && !ablation_items.empty()) report["ablation"] = std::move(ablation_items);
  if (o.timing) report["timing"] = Json{{"wall_s", seconds_since(t0)}, {"scenes", timing_scenes}};
  const fs::path json_path = o.out / "report.json";
  {
    std::ofstream out(json_path);
    out << report.dump(2) << "\n";
    if (!out) {
      std::fprintf(stderr, "gauss-eval: cannot write %s\n", json_path.c_str());
      return 1;
    }
  }
  if (report.contains("ablation") && o.images) report["plots"] = plot_ablation(o, json_path);
  if (auto st = write_markdown(o.out / "report.md", report, o.images); !st) {
    std::fprintf(stderr, "gauss-eval: %s\n", st.message().c_str());
    return 1;
  }
  const Json& checks = report["checks"];
  std::printf("gauss-eval: wrote %s and report.md\n", json_path.c_str());
  std::printf("  HS = host render of the sent set: %s (%llu differing pixels)\n",
              checks["hs_equals_sent_render"].get<bool>() ? "yes" : "NO",
              static_cast<unsigned long long>(checks["hs_vs_sent_differing_pixels"].get<std::uint64_t>()));
  if (o.realtime) {
    std::printf("  published set = the host's dump: %s; the dump = this scene: %s\n",
                checks["published_equals_sent"].get<bool>() ? "yes" : "NO",
                checks["sent_matches_scene"].get<bool>() ? "yes" : "NO");
  }
  if (checks.contains("semantic_shares_match")) {
    std::printf("  semantic shares = min(|G_obj|, floor(rho M)) / M: %s\n",
                checks["semantic_shares_match"].get<bool>() ? "yes" : "NO");
  }
  std::printf("  every view converged: %s\n", checks["all_converged"].get<bool>() ? "yes" : "NO");
  for (const auto& [name, value] : checks.items())
    if (value.is_boolean() && !value.get<bool>()) rc = 1;
  if (report["validation_errors"].get<std::uint64_t>() != 0) rc = 1;
  return rc;
}
