#pragma once
// Camera JSON files (OpenCV/COLMAP convention, see camera.h):
//   { "width": 320, "height": 180, "fx": .., "fy": .., "cx": .., "cy": ..,
//     "world_to_camera": [[r00, r01, r02, tx], [r10, r11, r12, ty], [r20, r21, r22, tz], [0, 0, 0, 1]],
//     "near": 0.2, "far": 1000 }            (near/far optional: Camera's defaults)
// world_to_camera is row-major nested arrays in the file; Camera stores it column-major
// (glm::dmat4, m[column][row]), so the reader and writer transpose.
//
// Rejected with a message naming the input and the key: missing keys or wrong JSON types,
// width/height not a positive integer (at most kMaxCameraDimension), fx/fy <= 0, any NaN/Inf,
// a rotation block that is not orthonormal within kCameraRotationTolerance (the message gives
// the measured deviation max|R^T R - I|) or is a reflection (det < 0), a bottom row other than
// 0 0 0 1 (within 1e-9; stored exactly), near <= 0, far <= near. Unknown keys are ignored.
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "gauss/engine/camera.h"
#include "gauss/engine/result.h"

namespace gauss {

inline constexpr double kCameraRotationTolerance = 1e-4;
inline constexpr std::uint32_t kMaxCameraDimension = 65536;

Expected<Camera> parse_camera_json(std::string_view text, std::string_view name);
Expected<Camera> read_camera_json(const std::filesystem::path& path);

// Validates a camera with the same rules the reader applies (name used in messages).
Status validate_camera(const Camera& camera, std::string_view name);

// JSON text of a valid camera (near/far included); doubles are written in shortest round-trip
// form, so write -> read is exact. Fails on a camera validate_camera rejects.
Expected<std::string> camera_to_json(const Camera& camera);
Status write_camera_json(const std::filesystem::path& path, const Camera& camera);

}  // namespace gauss
