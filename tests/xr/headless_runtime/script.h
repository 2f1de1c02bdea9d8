#pragma once
// The scripted headset: what the runtime reports (view size, frame period, field of view,
// stage bounds), how the head and the two controllers move, which session events happen,
// and which frames are captured. Read from the JSON file named by GAUSS_XR_HEADLESS_SCRIPT
// at xrCreateInstance; without it the defaults below apply. The format is in README.md.
//
// Poses are in STAGE space (see spaces.cpp); orientations are written w, x, y, z in the
// file. A keyframe changes only the fields it names; state holds until the next keyframe
// (no interpolation), and frames before the first keyframe use the defaults.
#include <cstdint>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "gauss/engine/result.h"
#include "xr_headers.h"

namespace gauss::xr_headless {

struct HandState {
  XrPosef aim{};
  XrPosef grip{};
  float trigger{0.0f};   // 0..1; "click" inputs read it as pressed above kClickThreshold
  float squeeze{0.0f};   // 0..1
  bool primary{false};   // a (right) / x (left)
  bool secondary{false}; // b (right) / y (left)
  bool menu{false};      // the left controller's menu button
  bool thumbstick_click{false};
  XrVector2f thumbstick{0.0f, 0.0f};  // each axis -1..1
};

// Analog inputs read through a boolean ("click") binding are pressed above this value.
inline constexpr float kClickThreshold = 0.5f;

struct TrackedState {
  XrPosef head{};
  HandState left;
  HandState right;
};

enum class ScriptEventKind { kLoss, kExit };

struct ScriptEvent {
  std::uint64_t frame{0};
  ScriptEventKind kind{ScriptEventKind::kExit};
};

struct Script {
  std::uint32_t width{320};   // recommended per-eye image size
  std::uint32_t height{240};
  std::int64_t period_ns{13'888'889};  // 72 Hz
  float ipd{0.064f};                   // metres between the eyes
  XrFovf fov[2]{};                     // left eye, right eye (radians)
  XrExtent2Df stage{4.0f, 3.0f};       // STAGE bounds, metres
  std::vector<std::pair<std::uint64_t, TrackedState>> keyframes;  // sorted, each fully resolved
  std::vector<ScriptEvent> events;     // sorted by frame
  bool capture_all{false};
  std::set<std::uint64_t> capture_frames;

  Script();  // the defaults: 320x240, +-45 degree half-angles, head at (0, 1.6, 0)

  // The tracked state at frame index `frame`.
  const TrackedState& at(std::uint64_t frame) const;
  bool captures(std::uint64_t frame) const { return capture_all || capture_frames.count(frame) != 0; }

 private:
  TrackedState defaults_;
};

// Parses a script. The error names the file and the JSON path of the bad value
// ("keyframes[2].right.trigger: expected a number in [0, 1]").
Expected<Script> parse_script(const std::string& json_text, const std::string& source_name);
Expected<Script> load_script(const std::filesystem::path& path);

}  // namespace gauss::xr_headless
