#pragma once
// gauss-view's command line (CLI11): the options, their defaults and their checks.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include <glm/vec3.hpp>

#include "gauss/engine/publisher.h"
#include "gauss/engine/scene_framing.h"
#include "gauss/net/address.h"

namespace gauss::view {

struct ViewOptions {
  // Source: a host (--host) or a local scene file (--scene); exactly one.
  std::optional<net::Endpoint> host;
  std::filesystem::path scene;
  std::filesystem::path mesh;          // local scene only: a surface mesh PLY
  std::string token;
  std::string name{"gauss-view"};
  std::uint32_t budget{200000};        // M, the client's slots
  PublishMode mode{PublishMode::Progressive};
  bool highlight{true};
  bool edit_tints{false};
  std::uint32_t frames_in_flight{2};
  bool publication_thread{true};       // a stream's publication off the display thread
  std::uint32_t width{640}, height{480};  // view size (headless: when the path has no camera; windowed: the window)
  double fov_deg{70.0};                // horizontal field of view of the default intrinsics
  // The scene's up (--up): unset, a local scene's up is detected (gauss/engine/scene_up.h:
  // the trainer's cameras.json, else the 3DGS default -y) and a stream's is +y.
  std::optional<glm::dvec3> up;
  // Which of the default camera's views a local scene opens with (--view; the keys F / 1, 2, 3
  // choose again in the window).
  ViewPreset view{ViewPreset::Front};
  double stereo_ipd{0.0};              // > 0: render both eyes (headless writes both)
  std::string device;                  // Vulkan device override

  // Headless
  bool headless{false};
  std::filesystem::path path;          // camera path JSON (needed with --host; a scene without one: its default camera)
  std::filesystem::path out{"out/view"};
  std::uint32_t every{1};              // PNG every N path frames (0: the final frame only)
  double settle_timeout_s{60.0};       // after the path: the longest wait for the stream to settle
  double quiet_s{1.5};                 // settled: nothing pending and no edits for this long
  std::uint64_t max_frames{100000};

  // Windowed
  std::filesystem::path screenshot;    // write the window after `screenshot_after` frames, then go on
  std::uint32_t screenshot_after{10};
  std::uint64_t exit_after{0};         // frames (0: until the window closes)
  bool no_ui{false};                   // no ImGui panels (the scene alone; tests compare against it)
  std::filesystem::path camera;        // start pose from this camera JSON (its intrinsics are not used)
  std::filesystem::path screenshot_dir{"."};  // the P key's PNGs: gauss-view-NNNN.png, never overwriting
  // Scripts and tests drive the window as a person would: `drop` is dropped on it after
  // `drop_after` frames (through its drop handler), `press_key` (GLFW_KEY_*, 0: none)
  // pressed after `press_after` frames. With a drop, --exit-after and --screenshot-after
  // count the frames after its load ended (succeeded or failed), so a shot shows its outcome.
  std::filesystem::path drop;
  std::uint32_t drop_after{2};
  int press_key{0};
  std::uint32_t press_after{2};
};

// Focal length in pixels of a pinhole `width` pixels wide with horizontal field of view
// `hfov_deg` (the default camera of --fov).
double focal_from_hfov(double hfov_deg, std::uint32_t width);

// Parses argv. Returns the exit status when the program should stop (0 after --help,
// 2 after a bad command line), else std::nullopt.
std::optional<int> parse_options(int argc, char** argv, ViewOptions& out);

}  // namespace gauss::view
