#pragma once
// Which way is up in a splat scene file, and where that was read.
//
// Splat files carry no up vector. The 3DGS trainer (and COLMAP before it) writes scenes in
// the capture's camera frame, OpenCV style: y points down (kColmapUp = -y), and that is the
// default here, since trainer output is what people open most. Tools that convert for the
// web (three.js, PlayCanvas, Blender exports) use y up or z up: those need --up.
// Where the trainer left its cameras.json (the capture's camera poses), the up vector is
// measured instead: the mean of the cameras' image-up directions, which is the capture's
// up whatever convention the file uses.
//
// Precedence (choose_scene_up): an explicit --up, then the trainer's cameras.json found
// beside the scene, then kColmapUp.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include <glm/vec3.hpp>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/result.h"

namespace gauss {

// The 3DGS / COLMAP convention: OpenCV camera frames, y down.
inline constexpr glm::dvec3 kColmapUp{0.0, -1.0, 0.0};

// Turns Gaussians a half turn about the x axis, (x, y, z) -> (x, -y, -z), which makes a
// y-down scene y-up: positions, rotations, and the SH rest coefficients whose basis
// functions are odd in y and z together (their sign flips; the turn is its own inverse, so
// nothing else changes). Exact: the turned Gaussians seen from a camera turned the same way
// render the image the originals give.
void half_turn_about_x(std::span<Gaussian> gaussians);

// "+x", "-x", "+y", "-y", "+z", "-z" (a bare "x" means "+x"; case-insensitive) to the unit
// axis. Errors name the text and list the accepted values.
Expected<glm::dvec3> parse_up_axis(std::string_view text);

// "+y" / "-z" for an axis, else the vector as "(0.02, -0.99, 0.10)".
std::string up_label(const glm::dvec3& up);

enum class UpSource : std::uint8_t { Option, TrainerCameras, Default };

struct SceneUp {
  glm::dvec3 up{kColmapUp};  // unit
  UpSource source{UpSource::Default};
  // Where it came from, for a person: "--up +z", "RUN/cameras.json (the capture's
  // cameras)", "default (3DGS/COLMAP: y down)".
  std::string detail{"default (3DGS/COLMAP: y down)"};
  // A cameras.json was found but could not be used: the reader's message; else empty.
  std::string problem;
  // Where the capture's cameras stood on average (cameras.json, when every camera gives a
  // finite "position"): the side a default camera should look from (scene_framing.h).
  std::optional<glm::dvec3> capture_position;
};

// The up of a capture from its cameras' axes in the world (OpenCV cameras: `right` = +x,
// `down` = +y of each camera, any length > 0). The mean image-up (-down) leans toward the
// cameras' view direction wherever they all pitch the same way (a partial arc, a forward-
// facing capture, an RGB-D walk looking down at desks: the shared SUN3D frames' mean is 10
// degrees from the up below). People rarely roll a camera, so its right axis is level: where
// the right axes span a plane (the smaller of its two spreads at least 5 % of the cameras:
// headings some 30 degrees apart or more), up is that plane's normal, on the mean image-up's
// side; with one heading, the mean image-up made perpendicular to the common right axis. A
// result more than 45 degrees from the mean image-up (portrait and landscape shots mixed:
// rolled cameras) gives way to the mean. Errors: the image-ups cancel (mean length at most
// 0.1: no agreed up), or no camera is finite.
struct CameraAxes {
  glm::dvec3 right{1.0, 0.0, 0.0};
  glm::dvec3 down{0.0, 1.0, 0.0};
};
Expected<glm::dvec3> capture_up(std::span<const CameraAxes> cameras);

// The trainer's cameras.json for a scene file: beside it, or at the run folder of the
// trainer's layout RUN/point_cloud/iteration_N/point_cloud.ply; for a snapshot folder (a RUN
// followed live, or any folder of snapshots), in it. nullopt when there is none.
std::optional<std::filesystem::path> find_trainer_cameras(const std::filesystem::path& scene);

struct TrainerCapture {
  glm::dvec3 up{kColmapUp};                // unit
  std::optional<glm::dvec3> mean_position;  // nullopt unless every camera has a finite one
  std::size_t cameras{0};
};

// The capture's up from a trainer cameras.json (a JSON array of {"rotation": 3x3 rows
// camera-to-world, "position": [x, y, z], ...}, as 3DGS writes it): capture_up of the
// rotations' first (right) and second (down) columns, and the cameras' mean position. Errors name
// the file and the first bad camera (not an array, no cameras, a rotation that is not 3 rows
// of 3 finite numbers) or say the cameras' up directions cancel out.
Expected<TrainerCapture> read_trainer_capture(const std::filesystem::path& cameras_json);

// The up for a scene file by the precedence above. A cameras.json that cannot be read falls
// back to the default, and `problem` says why (the scene itself still opens).
SceneUp choose_scene_up(const std::optional<glm::dvec3>& option, const std::filesystem::path& scene);

}  // namespace gauss
