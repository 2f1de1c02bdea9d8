#pragma once
// The peer renderer of `gauss-bench render --peer BIN`: shg8/3DGS.cpp (LGPL-2.1) built with
// ../shared/gpu/peer/3dgs_bench.patch, a headless driver and a subgroup-size fix, no algorithm
// change (../shared/gpu/peer/ holds a build; ../shared/gpu/README.md). Its command line:
//   BIN scene.ply --width W --height H --fov DEG --warmup K --frames N
// renders the PLY from the origin looking down -z with horizontal field of view DEG (the box
// cameras' view), K warm-up frames then N measured ones, and ends with the line
//   median_wall_ms X | <pass> <ms> ...
// of which X, the median wall ms per frame of the N, is what we compare with our wall median.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gauss/engine/result.h"

namespace gauss::bench {

struct PeerRunInfo {
  std::filesystem::path binary;
  std::filesystem::path scene;  // a box scene PLY (write_box_ply)
  std::uint32_t width{0}, height{0};
  double fov_deg{45.0};
  int warmup{3};  // as ../shared/gpu/device-run.sh and the H100 table of issue 24
  int frames{5};
  int timeout_s{600};
};

// Checks that `binary` is a file we may execute; the error names the path and why not.
Status check_peer_binary(const std::filesystem::path& binary);

// Runs the peer once (its own process, output to a log beside the scene, ended by its pid on
// timeout) and returns its median wall ms per frame. Errors say why it gave none: it could
// not be started, it exited with a status or a signal (with the last lines of its output, e.g.
// the loader's missing library or Vulkan's "no device"), it timed out, or it printed no
// median_wall_ms line.
Expected<double> run_peer(const PeerRunInfo& info);

// The horizontal field of view in degrees of a pinhole camera `width` pixels wide with focal
// length fx: the peer's camera is given the box camera's.
double horizontal_fov_deg(std::uint32_t width, double fx);

// The comparison's figures for one size, each the median over the rounds; 0 = no figure.
struct PeerRow {
  std::string size;
  double peer_ms{0}, ours_ms{0};
  std::string note;  // why a figure is missing
};

// Prints the ours/peer table, one line per size.
void print_peer_summary(const std::vector<PeerRow>& rows, const std::filesystem::path& binary, int rounds, int frames);
// The same as JSON: binary, rounds, warm-up frames and one object per size.
nlohmann::json peer_summary_json(const std::vector<PeerRow>& rows, const std::filesystem::path& binary, int rounds);

// A folder for the peer's scene files and logs under the temp directory, removed with
// everything in it when this goes (also when the run stops early).
struct PeerWorkDir {
  std::filesystem::path path;
  PeerWorkDir();
  ~PeerWorkDir();
  PeerWorkDir(const PeerWorkDir&) = delete;
  PeerWorkDir& operator=(const PeerWorkDir&) = delete;
};

}  // namespace gauss::bench
