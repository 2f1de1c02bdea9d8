#pragma once
// gauss-fuse's command line (CLI11): the options, their defaults and their checks.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>

namespace gauss::fuse_app {

struct Options {
  std::filesystem::path rgbd;   // RGB-D folder (3DMatch/SUN3D, TUM or Replica layout)
  std::filesystem::path out;    // mesh PLY to write
  float voxel_size{0.02f};      // metres
  float truncation{0.0f};       // metres; 0 = 3 voxels (the TSDF's default)
  float min_depth{0.1f};        // metres; depths outside [min, max] count as missing
  float max_depth{8.0f};
  std::uint32_t max_blocks{200000};  // TSDF memory bound: 8^3-voxel blocks, ~6 KiB each
  std::size_t first{0};         // index of the first listed frame to use
  std::size_t stride{1};        // use every stride-th frame from `first`
  std::size_t frames{0};        // at most this many frames; 0 = all selected
  bool skip_bad{false};         // a frame that cannot be loaded or fused is skipped, not fatal
  bool ascii{false};            // ASCII PLY instead of binary little endian
};

// Parses argv. Returns the exit status when the program should stop (0 after --help,
// 2 after a bad command line, CLI11's message printed), else std::nullopt.
std::optional<int> parse_options(int argc, char** argv, Options& out);

}  // namespace gauss::fuse_app
