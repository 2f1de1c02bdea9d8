#pragma once
// The two index files of the Replica RGB-D layout (NICE-SLAM's rendering of the Replica
// rooms): cam_params.json (intrinsics, image size, depth scale) and traj.txt (one row-major
// 4x4 camera-to-world per line). Private to the RGB-D folder source.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <glm/mat4x4.hpp>

#include "gauss/engine/result.h"

namespace gauss::replica {

struct CameraParams {
  std::uint32_t width{0}, height{0};
  double fx{0}, fy{0}, cx{0}, cy{0};
  double depth_scale{0};  // depth PNG units per metre (6553.5 in NICE-SLAM's Replica)
};

// Reads {"camera": {"w", "h", "fx", "fy", "cx", "cy", "scale"}}. Errors name the file and
// the member that is missing, not a number or out of range, or where the JSON is broken.
Expected<CameraParams> read_cam_params(const std::filesystem::path& path);

// One traj.txt line: the pose, or (error non-empty) why that line is not one, so only the
// frame that needs the line fails.
struct TrajectoryRow {
  glm::dmat4 camera_to_world{1.0};
  std::string error;
};

// Reads traj.txt: a row per non-empty line. Errors only when the file cannot be read.
Expected<std::vector<TrajectoryRow>> read_trajectory(const std::filesystem::path& path);

}  // namespace gauss::replica
