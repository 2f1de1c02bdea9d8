#include "options.h"

#include "gauss/engine/rgbd_scene.h"

#include <charconv>
#include <cstdio>
#include <sstream>

#include "gauss_cli.h"

namespace gauss::eval_app {

namespace {

// Why the options cannot run with --realtime (empty: they can).
std::string realtime_conflict(const Options& o) {
  if (!o.realtime) return {};
  if (!o.timing)
    return "--realtime contradicts --no-timing: every realtime figure is a wall-clock measurement, and "
           "--no-timing leaves those out";
  if (o.surface == "analytic")
    return "--realtime --surface analytic: gauss-host streams no analytic surface; use --surface none";
  if (!o.ablation_budgets.empty() || o.stereo_budget)
    return "--realtime: --ablation and --stereo-budget are runs of the deterministic evaluation; leave them out";
  if (o.lod == "both")
    return "--realtime serves one gauss-host: --lod on (its default) or --lod off, not both";
  return {};
}

}  // namespace

std::optional<int> parse_options(int argc, char** argv, Options& o) {
  CLI::App app{
      "gauss-eval: the paper's evaluation on the real client path. An in-process host (HostSession\n"
      "over the scene) streams to a ClientRuntime through a modelled link on a virtual clock; every\n"
      "image is a real render. Per synthetic room: the fidelity chain GT -> PC (host render of the\n"
      "full float scene) -> HS (the client's converged frame), HS against the host's render of the\n"
      "set it sent (must be bit-exact), the semantic reallocation table, the teleport convergence\n"
      "and flicker per publication mode, the stage latencies of model edits and queries (each of\n"
      "these can be skipped), and with --ablation the budget ablation (plotted by --plot-script).\n"
      "Writes report.json (deterministic: the same command gives the same bytes; wall-clock\n"
      "figures only under \"timing\", left out by --no-timing), report.md and PNGs.\n"
      "Exit status: 0 written and every exactness check held; 1 an error, or a check failed\n"
      "(HS differs from the host's render of the sent set, a share differs from\n"
      "min(|G_obj|, floor(rho M))/M, a view did not converge); 2 bad arguments.\n"
      "--realtime instead runs gauss-host as a child process serving the same scene and the real\n"
      "client over loopback ENet on the wall clock: per fidelity camera a fresh connection settles\n"
      "(--quiet, --settle-timeout in wall seconds), its frame is compared with GT and PC and, after\n"
      "it disconnects, with the host's render of the set the host's --dump-sent says it sent; then a\n"
      "teleport far and back per publication mode with a flicker window at the start view, and each\n"
      "semantic query at its near view (its share exact). Wall-clock figures: they do not reproduce.",
      "gauss-eval"};
  apps::configure(app);
#ifdef GAUSS_SOURCE_DIR
  o.plot_script = GAUSS_SOURCE_DIR "/scripts/plot_eval.py";
#endif
  auto* rooms = app.add_option("--scenes", o.variants, "synthetic room variants, comma separated")
                    ->delimiter(',')
                    ->check(apps::in_range(0, 3))
                    ->type_name("V,...");
  auto* scene = app.add_option("--scene", o.scene_file,
                               "also (or, without --scenes, only) this scene file, SOG folder or snapshot folder (its "
                               "snapshots in order; the last is evaluated, all replayed for the model-edit latencies): "
                               "no ground truth, GT columns n/a, cameras orbiting it")
                    ->check(CLI::ExistingPath)
                    ->type_name("PATH");
  app.add_option("--labels", o.labels, "per-Gaussian labels of --scene")->check(CLI::ExistingFile)->needs(scene);
  app.add_option("--objects", o.objects, "objects JSON of --scene")->check(CLI::ExistingFile)->needs(scene);
  apps::add_up_option(app, o.up,
                      "the up axis of --scene: +x -x +y -y +z -z (default: as gauss-host decides it, a trainer "
                      "cameras.json beside the scene, else -y, the 3DGS/COLMAP convention; an RGB-D capture's "
                      "comes from its cameras)")
      ->needs(scene);
  app.add_option("--rgbd-stride", o.rgbd_stride,
                 "--scene is an RGB-D capture: one Gaussian per STRIDE x STRIDE pixel block (as gauss-host)")
      ->check(apps::in_range(1u, 64u))
      ->needs(scene);
  app.add_option("--gaussians", o.gaussians, "appearance Gaussians of each fully observed room")
      ->check(apps::in_range<std::size_t>(1000, 1000000));
  app.add_option("--epochs", o.epochs, "scene epochs produced before the evaluation")->check(apps::in_range(1, 64));
  app.add_option("--seed", o.seed, "seed of the synthetic rooms");
  app.add_option("--budget", o.budget, "M: the client's slots")->check(apps::in_range<std::uint32_t>(1, 400000));
  std::string size = std::to_string(o.width) + "x" + std::to_string(o.height);
  app.add_option("--size", size, "view size of every camera")->check(apps::image_size());
  app.add_option("--cameras", o.cameras, "fidelity cameras per room (from its trajectory)")
      ->check(apps::in_range<std::uint32_t>(1, 64));
  app.add_option("--rho", o.rho, "reservation fraction of a query")->check(apps::in_range(0.0, 1.0));
  app.add_option("--semantic-budget", o.semantic_budget,
                 "M of each semantic query's connection; 0 = the target's size |G_obj| (share about rho)")
      ->check(apps::in_range<std::uint32_t>(0, 400000));
  app.add_option("--class-query", o.class_query, "class query of the semantic table");
  app.add_option("--instance-label", o.instance_label, "instance query: the first object with this label");
  app.add_option("--instance-id", o.instance_id, "instance query: this object id (instead of --instance-label)")
      ->check(apps::in_range<std::int64_t>(0, 0xFFFFFFFFll));
  std::string mode = o.progressive ? "progressive" : "immediate";
  app.add_option("--mode", mode, "publication mode of the fidelity and semantic runs")
      ->check(CLI::IsMember({"progressive", "immediate"}));
  app.add_option("--allowance", o.allowance, "progressive publication: slot edits per frame (fixed)")
      ->check(apps::in_range<std::uint32_t>(1, 400000));
  app.add_option("--display-hz", o.display_hz, "virtual display rate")->check(apps::in_range(1.0, 1000.0));
  app.add_option("--latency-ms", o.latency_ms, "one-way link latency")->check(apps::in_range(0.0, 10000.0));
  app.add_option("--bandwidth-mbps", o.bandwidth_mbps, "link bandwidth")->check(apps::in_range(0.1, 100000.0));
  app.add_option("--settle-timeout", o.settle_timeout_s, "virtual seconds a view may take to converge")
      ->check(apps::in_range(0.1, 3600.0));
  app.add_option("--quiet", o.quiet_s, "virtual seconds in sync before a view counts as converged")
      ->check(apps::in_range(0.05, 60.0));
  auto* lod = app.add_option("--lod", o.lod,
                 "the host's level of detail: off (the best Gaussians only), on (what the budget cannot hold in "
                 "detail as a coarse cut through a merge hierarchy), both (every run with it, and the fidelity "
                 "chain and the ablation also without, side by side; --realtime serves one host: on, its default, "
                 "or off)")
      ->check(CLI::IsMember({"off", "on", "both"}));
  app.add_option("--surface", o.surface,
                 "surface the host streams: none (splats alone), analytic (a room's exact mesh as one chunk; "
                 "rooms only) or fused (an RGB-D capture's depth fused into a TSDF at 4 cm, as gauss-host does; "
                 "a capture only)")
      ->check(CLI::IsMember({"none", "analytic", "fused"}));
  app.add_flag_callback("--no-semantic", [&o] { o.semantic = false; }, "skip the semantic reallocation table");
  app.add_flag_callback("--no-temporal", [&o] { o.temporal = false; }, "skip the teleport convergence and flicker runs");
  app.add_option("--flicker-window", o.flicker_window_s, "virtual seconds of head sway after convergence (flicker)")
      ->check(apps::in_range(0.1, 600.0));
  app.add_flag_callback("--no-latency", [&o] { o.latency = false; },
                        "skip the stage latencies of model edits (the live room)");
  app.add_option("--epoch-period", o.epoch_period_s, "the live room's epoch period, virtual seconds")
      ->check(apps::in_range(0.01, 60.0));
  app.add_option("--stereo-budget", o.stereo_budget,
                 "frame timing while publication runs: stereo at this M after a far teleport (0: not run)")
      ->check(apps::in_range<std::uint32_t>(0, 400000));
  app.add_option("--ipd", o.ipd, "eye separation of the stereo frame timing, metres")->check(apps::in_range(0.0, 0.2));
  app.add_option("--ablation", o.ablation_budgets, "budget ablation over these M (e.g. 25000,50000,100000)")
      ->delimiter(',')
      ->check(apps::in_range<std::uint32_t>(1, 400000))
      ->type_name("M,...");
  std::vector<std::string> sizes;
  app.add_option("--ablation-sizes", sizes, "view sizes of the budget ablation (default: --size)")
      ->delimiter(',')
      ->check(apps::image_size())
      ->type_name("WxH,...");
  app.add_option("--plot-script", o.plot_script, "the ablation's plot script, run with /usr/bin/python3 (empty: none)")
      ->type_name("PY");
  app.add_option("--name", o.name, "report name (docs/results/<name>/)");
  app.add_option("--out", o.out, "output folder (default docs/results/<name>)")->type_name("DIR");
  app.add_flag_callback("--no-timing", [&o] { o.timing = false; },
                        "leave the wall-clock figures out (report.json then reproduces exactly)");
  app.add_flag("--realtime", o.realtime,
               "host and client as processes over loopback ENet on the wall clock (see above); needs timing, "
               "the real client's adaptive allowance replaces --allowance; no latency, flicker or ablation runs");
  app.add_option("--host-exe", o.host_exe, "--realtime: the gauss-host to start (default: the one beside gauss-eval)")
      ->type_name("PATH");
  app.add_flag_callback("--no-images", [&o] { o.images = false; }, "write no PNGs");
  app.add_option("--device", o.device, "Vulkan device index or name substring (else $GAUSS_DEVICE, else the best)")
      ->type_name("NAME");
  if (auto rc = apps::parse(app, argc, argv)) return rc;
  if (o.realtime && lod->count() == 0) o.lod = "on";  // one host process: no side-by-side run
  if (const std::string why = realtime_conflict(o); !why.empty()) {
    std::fprintf(stderr, "%s\nRun with --help for more information.\n", why.c_str());
    return apps::kUsageError;
  }
  const auto wh = apps::parse_size(size);
  o.width = wh->first;
  o.height = wh->second;
  o.progressive = mode == "progressive";
  if (!o.scene_file.empty() && rooms->count() == 0) o.variants.clear();
  // Each surface kind belongs to one kind of scene: a run that could not stream it is refused.
  const bool capture = !o.scene_file.empty() && is_rgbd_capture(o.scene_file);
  if ((o.surface == "fused" && !capture) || (o.surface == "analytic" && o.variants.empty())) {
    std::fprintf(stderr, "--surface %s: %s\nRun with --help for more information.\n", o.surface.c_str(),
                 o.surface == "fused" ? "needs --scene to be an RGB-D capture" : "needs a synthetic room (--scenes)");
    return apps::kUsageError;
  }
  for (const std::string& sz : sizes) o.ablation_sizes.push_back(*apps::parse_size(sz));
  if (o.ablation_sizes.empty()) o.ablation_sizes.emplace_back(o.width, o.height);
  if (o.out.empty()) o.out = std::filesystem::path("docs/results") / o.name;
  return std::nullopt;
}

std::string shortest(double v) {
  char b[64];
  const auto r = std::to_chars(b, b + sizeof b, v);
  return std::string(b, r.ptr);
}

std::string canonical_command(const Options& o) {
  auto join = [](const auto& v) {
    std::string s;
    for (const auto& x : v) s += (s.empty() ? "" : ",") + std::to_string(x);
    return s;
  };
  std::ostringstream c;
  c << "gauss-eval";
  if (!o.variants.empty()) c << " --scenes " << join(o.variants);
  if (!o.scene_file.empty()) {
    c << " --scene '" << o.scene_file.string() << "'";
    if (is_rgbd_capture(o.scene_file))  // its up comes from its cameras
      c << " --rgbd-stride " << o.rgbd_stride;
    else if (o.up)
      c << " --up " << up_label(*o.up);
    if (!o.labels.empty()) c << " --labels '" << o.labels.string() << "'";
    if (!o.objects.empty()) c << " --objects '" << o.objects.string() << "'";
  }
  if (o.realtime) {
    // Only what a realtime run reads: no link model, allowance or deterministic-only run.
    c << " --realtime --gaussians " << o.gaussians << " --epochs " << o.epochs << " --seed " << o.seed << " --budget "
      << o.budget << " --size " << o.width << "x" << o.height << " --cameras " << o.cameras << " --rho "
      << shortest(o.rho) << " --mode " << (o.progressive ? "progressive" : "immediate") << " --display-hz "
      << shortest(o.display_hz) << " --settle-timeout " << shortest(o.settle_timeout_s) << " --quiet "
      << shortest(o.quiet_s) << " --surface " << o.surface << " --lod " << o.lod << " --name " << o.name;
    if (!o.host_exe.empty()) c << " --host-exe '" << o.host_exe.string() << "'";
    if (!o.images) c << " --no-images";
    return c.str();
  }
  c << " --gaussians " << o.gaussians << " --epochs " << o.epochs
    << " --seed " << o.seed << " --budget " << o.budget << " --size " << o.width << "x" << o.height << " --cameras "
    << o.cameras << " --rho " << shortest(o.rho) << " --semantic-budget " << o.semantic_budget << " --class-query '" << o.class_query << "' --instance-label '"
    << o.instance_label << "'" << (o.instance_id >= 0 ? " --instance-id " + std::to_string(o.instance_id) : std::string())
    << " --mode " << (o.progressive ? "progressive" : "immediate") << " --allowance "
    << o.allowance << " --display-hz " << shortest(o.display_hz) << " --latency-ms " << shortest(o.latency_ms) << " --bandwidth-mbps "
    << shortest(o.bandwidth_mbps) << " --settle-timeout " << shortest(o.settle_timeout_s) << " --quiet " << shortest(o.quiet_s) << " --surface "
    << o.surface << " --lod " << o.lod;
  if (!o.semantic) c << " --no-semantic";
  if (!o.temporal) c << " --no-temporal";
  c << " --flicker-window " << shortest(o.flicker_window_s);
  if (!o.latency) c << " --no-latency";
  c << " --epoch-period " << shortest(o.epoch_period_s);
  if (o.stereo_budget) c << " --stereo-budget " << o.stereo_budget << " --ipd " << shortest(o.ipd);
  if (!o.ablation_budgets.empty()) {
    c << " --ablation " << join(o.ablation_budgets) << " --ablation-sizes ";
    for (std::size_t i = 0; i < o.ablation_sizes.size(); ++i)
      c << (i ? "," : "") << o.ablation_sizes[i].first << "x" << o.ablation_sizes[i].second;
  }
  c << " --name " << o.name;
  if (!o.timing) c << " --no-timing";
  if (!o.images) c << " --no-images";
  return c.str();
}

}  // namespace gauss::eval_app
