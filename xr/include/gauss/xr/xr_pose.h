#pragma once
// The OpenXR boundary: OpenXR poses (y up, -z forward, right-handed) and field-of-view
// angles become the engine's OpenCV cameras (x right, y down, z forward) here, once.
// Nothing past this header sees an OpenXR convention.
#include <cstdint>

#include <glm/gtc/quaternion.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "gauss/engine/camera.h"

namespace gauss::xr {

// An OpenXR pose: orientation (unit quaternion) and position of a view in the
// OpenXR reference space. Mirrors XrPosef without depending on openxr.h.
struct XrPose {
  glm::dquat orientation{1.0, 0.0, 0.0, 0.0};  // glm::dquat(w, x, y, z)
  glm::dvec3 position{0.0};
};

// Field of view as OpenXR gives it (XrFovf): signed angles in radians from the view
// axis; angle_left and angle_down are normally negative.
struct XrFov {
  double angle_left{0.0}, angle_right{0.0}, angle_up{0.0}, angle_down{0.0};
};

// Builds the OpenCV camera for one eye. T_scene_space maps the OpenXR reference space
// into the scene's world frame (identity when the scene was authored in that space).
// Returns false (camera untouched) for a non-finite pose, an unnormalisable orientation,
// or a degenerate field of view (right <= left, up <= down, or a half-angle >= 90 deg).
bool eye_camera(const XrPose& pose, const XrFov& fov, std::uint32_t width, std::uint32_t height,
                const glm::dmat4& T_scene_space, Camera& out_camera);

// The inverse direction for a rendered camera: the OpenXR pose of an OpenCV camera
// (used to send the coarse head pose and to test the round trip).
XrPose pose_of_camera(const Camera& camera, const glm::dmat4& T_scene_space);

}  // namespace gauss::xr
