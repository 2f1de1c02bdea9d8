#pragma once
// gauss-render's command line (CLI11): the options, their defaults and their checks.
#include <filesystem>
#include <optional>
#include <string>

#include <glm/vec3.hpp>

namespace gauss::render_app {

struct Options {
  std::filesystem::path scene, mesh, camera, out, compare;
  std::filesystem::path order;  // JSON array of gaussian_ids: the slot order to render in
  bool reference{false};  // CPU reference rasterizer instead of the GPU renderer
  bool stereo{false};     // --stereo given
  double ipd{0.0};        // metres between the eyes
  std::string device;     // Vulkan device index or name substring; empty: $GAUSS_DEVICE, else the best
  glm::dvec3 clear{0.0};  // background without a mesh
  int frames{1};          // GPU: renders of the view, each with its pass times
  unsigned threads{1};    // --reference: blend threads
};

// Parses argv. Returns the exit status when the program should stop (0 after --help,
// 2 after a bad command line, CLI11's message printed), else std::nullopt.
std::optional<int> parse_options(int argc, char** argv, Options& out);

}  // namespace gauss::render_app
