#pragma once
// gauss-eval's command line (CLI11): the options, their defaults and their checks.
// The defaults are the small configuration CI runs (a few seconds per room on lavapipe);
// the README of docs/results/ names the larger runs.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

namespace gauss::eval_app {

struct Options {
  std::vector<int> variants{0, 1, 2, 3};  // synthetic room variants evaluated, in this order
  // A scene file (any splat format the host reads, or a SOG folder), evaluated after the
  // rooms without ground truth. Given alone, no room is evaluated unless --scenes says so.
  std::filesystem::path scene_file;
  std::filesystem::path labels;           // per-Gaussian labels of --scene (labels file)
  std::filesystem::path objects;          // objects JSON of --scene (names the labels)
  // --scene's up axis as given (--up); unset: the rule gauss-host follows (choose_scene_up:
  // a trainer's cameras.json beside it, else -y). Its orbit cameras stand upright for it.
  std::optional<glm::dvec3> up;
  std::uint32_t rgbd_stride{4};           // an RGB-D capture: a Gaussian per stride x stride pixels (as gauss-host)
  std::size_t gaussians{20000};           // appearance Gaussians of each fully observed room
  int epochs{12};                         // epochs produced before the evaluation (the room then stays)
  std::uint64_t seed{1};                  // the synthetic scenes' seed
  std::uint32_t budget{5000};             // M: the client's slots
  std::uint32_t width{160}, height{120};  // view size of every camera
  std::uint32_t cameras{3};               // fidelity cameras per room, from the room's own trajectory
  double rho{0.9};                        // reservation fraction a query asks for
  // M of each semantic query's connection; 0 = the object's size |G_obj|, so the reserve
  // floor(rho M) is below it and the share is about rho (the regime of the paper's table).
  std::uint32_t semantic_budget{0};
  std::string class_query{"chair"};       // class query of the semantic table
  std::string instance_label{"robot_arm"};  // instance query: the first object with this label
  std::int64_t instance_id{-1};           // instance query by object id instead (>= 0)
  bool progressive{true};                 // publication mode of the fidelity and semantic runs
  std::uint32_t allowance{2000};          // progressive: slot edits per frame (fixed: deterministic)
  double display_hz{72.0};                // virtual display rate
  double latency_ms{5.0};                 // one-way link latency (both directions)
  double bandwidth_mbps{100.0};           // link bandwidth (both directions)
  double settle_timeout_s{20.0};          // virtual seconds a view may take to converge
  double quiet_s{0.5};                    // virtual seconds in sync before a view counts as converged
  // The host's level of detail (HostSessionConfig::lod): off (leaf selection), on (a coarse
  // cut for the background), both (every run with LoD; the fidelity chain and the ablation
  // also without, side by side).
  std::string lod{"both"};
  bool lod_on() const { return lod != "off"; }
  std::string surface{"none"};            // none | analytic (a room) | fused (a capture): the host's surface
  bool semantic{true};                    // the semantic reallocation table
  bool temporal{true};                    // teleport far and return, per publication mode
  double flicker_window_s{2.0};           // virtual seconds of head sway after convergence
  bool latency{true};                     // stage latencies of model edits (a live room)
  double epoch_period_s{0.1};             // the live room's epoch period
  std::uint32_t stereo_budget{0};         // M of the stereo frame-timing run (0: not run; the figure: 200000)
  double ipd{0.064};                      // its eye separation, metres
  std::vector<std::uint32_t> ablation_budgets;  // budget ablation (empty: none)
  std::vector<std::pair<std::uint32_t, std::uint32_t>> ablation_sizes;  // its view sizes (empty: --size)
  std::string plot_script;                // scripts/plot_eval.py of the source tree (empty: no plots)
  std::string name{"synthetic"};          // report name: docs/results/<name>/
  std::filesystem::path out;              // output folder (empty: docs/results/<name>)
  bool timing{true};                      // wall-clock figures under "timing"
  bool images{true};                      // PNGs and the images in report.md
  std::string device;                     // Vulkan device index or name substring
  // Host and client as processes over loopback ENet on the wall clock (realtime.cpp)
  // instead of the deterministic simulation; needs timing.
  bool realtime{false};
  std::filesystem::path host_exe;         // --realtime's gauss-host (empty: beside this executable)
};

// Parses argv. Returns the exit status when the program should stop (0 after --help,
// 2 after a bad command line, CLI11's message printed), else std::nullopt.
std::optional<int> parse_options(int argc, char** argv, Options& out);

// The command that reproduces the deterministic part of a run (every option spelled out,
// --out and --device left out: they do not change report.json); for --realtime, the
// command that repeats the run's setup (its figures do not reproduce).
std::string canonical_command(const Options& o);

// A double in its shortest form that reads back exactly ("0.9", "72", "1e-05").
std::string shortest(double v);

}  // namespace gauss::eval_app
