#pragma once
// The OpenXR boundary: OpenXR poses (y up, -z forward, right-handed) and field-of-view
// angles become the engine's OpenCV cameras (x right, y down, z forward) here, once.
// Nothing past this header sees an OpenXR convention.
#include <cstdint>
#include <optional>

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

// T_scene_space for a scene whose up is `scene_up` (SceneInfo::view): a rotation about the
// reference space's origin that takes its +y (the room's up) to scene_up, so the scene stands
// upright in the room and the user starts where the scene's origin is (a 3DGS capture's first
// camera). With `face`, a scene point (the subject's centre), it is also turned about the
// room's up so that the point lies straight ahead (the reference space's -z) of the origin;
// a point above or below the origin leaves the heading as it is. -y (the 3DGS convention)
// without `face` is the half turn about x, exactly; +y, or a zero or non-finite up, the
// identity (a non-finite `face` is ignored).
glm::dmat4 scene_from_space(const glm::dvec3& scene_up, const std::optional<glm::dvec3>& face = std::nullopt);

// The inverse direction for a rendered camera: the OpenXR pose of an OpenCV camera
// (used to send the coarse head pose and to test the round trip).
XrPose pose_of_camera(const Camera& camera, const glm::dmat4& T_scene_space);

}  // namespace gauss::xr
