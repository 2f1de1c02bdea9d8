#pragma once
// Camera path files: what a headless client (gauss-view --headless, gauss-eval) flies.
//
//   {
//     "camera": {"width": 320, "height": 240, "fx": 250, "fy": 250, "cx": 160, "cy": 120},
//     "fps": 30,
//     "keyframes": [
//       {"t": 0.0, "eye": [0, 1.5, -2], "look_at": [0, 1, 2]},
//       {"t": 4.0, "eye": [1, 1.5, -2], "look_at": [0, 1, 2], "up": [0, 1, 0]},
//       {"t": 4.0, "eye": [9, 1.5, 9],  "look_at": [0, 1, 0], "cut": true}
//     ],
//     "events": [
//       {"t": 2.0, "query": {"class": "chair", "rho": 0.5}},
//       {"t": 2.5, "query": {"instance": 7, "rho": 0.3}},
//       {"t": 3.0, "clear": true},
//       {"t": 3.5, "mode": "immediate"}
//     ],
//     "settle_s": 10
//   }
//
// Poses: OpenCV cameras at `eye` looking at `look_at`, image-up near `up` (default +y,
// the synthetic rooms' up). Between two keyframes eye and look_at move linearly; a
// keyframe with "cut": true is a teleport: the previous pose holds until its time, then
// the view jumps. Times are seconds from the start, non-decreasing. "camera" gives the
// intrinsics (optional: the program's own size and field of view otherwise). "fps" is the
// frame rate of the path's clock (default 30). "settle_s" (default 0): after the last
// keyframe, the client keeps the final pose for up to this long, until its stream has
// settled (see gauss-view). Unknown keys are ignored.
//
// Bad input: a JSON syntax error names the line and column; a bad field names its path
// ("keyframes[2].eye: expected 3 finite numbers"); keyframes out of time order, an eye
// equal to its look_at, a non-finite number, an unknown event are all errors.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/camera.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/publisher.h"
#include "gauss/engine/result.h"

namespace gauss::client {

struct PathKeyframe {
  double t{0.0};
  glm::dvec3 eye{0.0};
  glm::dvec3 look_at{0.0, 0.0, 1.0};
  glm::dvec3 up{0.0, 1.0, 0.0};
  bool cut{false};
};

enum class PathEventKind : std::uint8_t { ClassQuery, InstanceQuery, Clear, Mode };

struct PathEvent {
  double t{0.0};
  PathEventKind kind{PathEventKind::Clear};
  std::string text;            // ClassQuery
  ObjectId instance{kNoObject};  // InstanceQuery
  float rho{0.0f};             // queries
  PublishMode mode{PublishMode::Progressive};  // Mode
};

struct CameraIntrinsics {
  std::uint32_t width{0}, height{0};
  double fx{0.0}, fy{0.0}, cx{0.0}, cy{0.0};
};

struct CameraPath {
  std::optional<CameraIntrinsics> intrinsics;
  double fps{30.0};
  double settle_s{0.0};
  std::vector<PathKeyframe> keyframes;  // at least one
  std::vector<PathEvent> events;        // sorted by time (stable)

  double duration() const noexcept { return keyframes.empty() ? 0.0 : keyframes.back().t; }
  // The camera at time t (clamped to the path), with `intrinsics` (width, height, fx..).
  Camera camera_at(double t, const CameraIntrinsics& intrinsics) const;
};

Expected<CameraPath> parse_camera_path(std::string_view text, std::string_view name);
Expected<CameraPath> read_camera_path(const std::filesystem::path& path);

}  // namespace gauss::client
