// gauss-bench identity: identity tracking of an id-less snapshot against the previous epoch.
// Previous epoch: a converged synthetic room of N Gaussians. Snapshot: 2 % removed, 5 %
// perturbed (0.3 sigma, small scale/colour/opacity steps), 2 % new, randomly permuted, ids
// stripped (make_trainer_snapshot, shared with the identity test); scenario "drift"
// additionally moves every Gaussian by 0.1 sigma and its SH0 by up to 0.01 (nothing is
// bit-identical, as between two trainer iterations). Reports the kept-id rates (the error
// figure) beside the tracking time (median of the runs; thread CPU time and wall time, one
// core: the tracker is single-threaded).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench_registry.h"
#include "bench_util.h"
#include "gauss_cli.h"
#include "gauss/engine/identity_tracker.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/synthetic_scene.h"
#include "gauss/engine/trainer_snapshot.h"

namespace {

using namespace gauss::bench;

using namespace gauss;

struct IdentityBenchOptions {
  std::size_t n{1'000'000};  // Gaussians in the previous epoch
  int runs{3};               // timed runs per scenario
  int variant{0};            // synthetic room variant
  std::string json_out;
};

int bench_identity_main(const IdentityBenchOptions& o) {
  const std::size_t n = o.n;
  const int runs = o.runs, variant = o.variant;
  const std::string& json_out = o.json_out;
  using clock = std::chrono::steady_clock;
  SyntheticSceneConfig cfg;
  cfg.variant = variant;
  cfg.target_gaussians = n;
  cfg.epochs = 8;
  cfg.converge_epochs = 2;
  const auto t_gen = clock::now();
  auto scene = SyntheticScene::create(cfg);
  if (!scene) {
    std::fprintf(stderr, "gauss-bench identity: %s\n", scene.message().c_str());
    return 1;
  }
  SceneStore store;
  gauss::apps::StatusLine status;  // seconds for a million Gaussians
  while (!scene->finished()) {
    status.update("generating the previous epoch: epoch " + std::to_string(scene->produced() + 1) + "/" +
                      std::to_string(scene->epoch_count()),
                  true);
    if (auto s = scene->produce(store); !s) {
      std::fprintf(stderr, "gauss-bench identity: %s\n", s.message().c_str());
      return 1;
    }
  }
  status.done({});
  const double gen_s = std::chrono::duration<double>(clock::now() - t_gen).count();
  std::vector<Gaussian> prev(store.gaussians().begin(), store.gaussians().end());
  std::uint64_t max_id = 0;
  for (const Gaussian& g : prev) max_id = std::max(max_id, to_underlying(g.id));
  std::printf("previous epoch: synthetic variant %d, %zu Gaussians (generated in %.2f s)\n\n", variant, prev.size(),
              gen_s);
  std::printf("%-12s %9s %9s %9s %9s | %11s %11s %11s | %8s %8s %9s\n", "scenario", "snapshot", "kept", "fresh",
              "removed", "unchanged%", "perturbed%", "new-fresh%", "cpu_s", "wall_s", "Mgauss/s");

  nlohmann::json rows = nlohmann::json::array();
  for (const float drift : {0.0f, 0.1f}) {
    const char* name = drift > 0.0f ? "drift" : "exact+5/2/2";
    const TrainerSnapshot base = make_trainer_snapshot(prev, {.drift_sigmas = drift}, 42);
    std::vector<double> times, cpu_times;
    IdentityReport report;
    std::vector<Gaussian> cur;
    for (int r = 0; r < runs; ++r) {
      cur = base.gaussians;
      std::uint64_t next = max_id + 1;
      const auto t0 = clock::now();
      const double c0 = thread_cpu_s();
      auto rep = track_identity(prev, cur, {}, [&] { return GaussianId{next++}; });
      cpu_times.push_back(thread_cpu_s() - c0);
      times.push_back(std::chrono::duration<double>(clock::now() - t0).count());
      if (!rep) {
        std::fprintf(stderr, "gauss-bench identity: %s\n", rep.message().c_str());
        return 1;
      }
      report = *rep;
    }
    std::sort(times.begin(), times.end());
    std::sort(cpu_times.begin(), cpu_times.end());
    const double median = times[times.size() / 2];
    const double cpu_median = cpu_times[cpu_times.size() / 2];
    std::size_t un = 0, un_kept = 0, pe = 0, pe_kept = 0, nw = 0, nw_fresh = 0;
    for (std::size_t i = 0; i < cur.size(); ++i) {
      const bool kept = cur[i].id == base.truth[i];
      switch (base.fate[i]) {
        case SnapshotFate::Unchanged: ++un; un_kept += kept; break;
        case SnapshotFate::Perturbed: ++pe; pe_kept += kept; break;
        case SnapshotFate::New: ++nw; nw_fresh += to_underlying(cur[i].id) > max_id; break;
      }
    }
    const auto pct = [](std::size_t a, std::size_t b) { return b ? 100.0 * double(a) / double(b) : 100.0; };
    std::printf("%-12s %9zu %9zu %9zu %9zu | %11.3f %11.3f %11.3f | %8.3f %8.3f %9.2f\n", name, report.current,
                report.kept, report.fresh, report.removed, pct(un_kept, un), pct(pe_kept, pe), pct(nw_fresh, nw),
                cpu_median, median, double(report.current) / cpu_median / 1e6);
    rows.push_back({{"scenario", name},
                    {"drift_sigma", drift},
                    {"previous", report.previous},
                    {"snapshot", report.current},
                    {"kept", report.kept},
                    {"exact", report.exact},
                    {"fresh", report.fresh},
                    {"removed", report.removed},
                    {"unchanged_kept_pct", pct(un_kept, un)},
                    {"perturbed_kept_pct", pct(pe_kept, pe)},
                    {"new_fresh_pct", pct(nw_fresh, nw)},
                    {"cell_size_m", report.cell_size},
                    {"median_cpu_s", cpu_median},
                    {"median_wall_s", median},
                    {"runs_cpu_s", cpu_times},
                    {"runs_wall_s", times}});
  }
  if (!json_out.empty()) {
    nlohmann::json doc = {{"bench", "identity"}, {"gaussians", prev.size()}, {"variant", variant},
                          {"generate_s", gen_s}, {"results", rows}};
    if (!write_json(json_out, doc, "identity")) return 1;
  }
  return 0;
}

BenchRun bench_identity_setup(CLI::App& cmd) {
  auto o = std::make_shared<IdentityBenchOptions>();
  cmd.add_option("--n", o->n, "Gaussians in the previous epoch")->check(gauss::apps::at_least<std::size_t>(1))->type_name("N");
  cmd.add_option("--runs", o->runs, "timed runs per scenario")->check(gauss::apps::at_least(1))->type_name("R");
  cmd.add_option("--variant", o->variant, "synthetic room variant")->check(gauss::apps::in_range(0, 3))->type_name("V");
  cmd.add_option("--json", o->json_out, "write the results as JSON")->type_name("FILE");
  return [o] { return bench_identity_main(*o); };
}

}  // namespace

GAUSS_BENCH("identity", "identity tracking of an id-less, permuted snapshot: kept-id rates and time (1M default)",
            bench_identity_setup);
