#pragma once
// gauss-host's command line (CLI11): the options, their defaults and their checks.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include "gauss/net/address.h"

namespace gauss::host_app {

struct Options {
  net::Endpoint bind{};        // 127.0.0.1 and the default port unless --bind
  std::string token;           // required access token; empty = none
  int variant{0};              // --scene synthetic:VARIANT
  std::size_t gaussians{100000};
  int epochs{12};
  double epoch_period_s{0.1};
  std::uint64_t seed{1};
  std::size_t max_clients{8};
  double duration_s{0.0};      // 0: until SIGINT/SIGTERM
  double surface_voxel{0.04};  // TSDF voxel (m) for the surface fused from each epoch's frames; 0 = none
  std::string events_path;     // empty: no event log
  std::filesystem::path dump_sent_dir;  // empty: no dumps
  bool quiet{false};
};

// Parses argv. Returns the exit status when the program should stop (0 after --help,
// 2 after a bad command line, CLI11's message printed), else std::nullopt.
std::optional<int> parse_options(int argc, char** argv, Options& out);

}  // namespace gauss::host_app
