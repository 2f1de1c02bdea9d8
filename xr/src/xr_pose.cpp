#include "gauss/xr/xr_pose.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "gauss/engine/gaussian.h"

namespace gauss::xr {
namespace {

// OpenXR view axes -> OpenCV camera axes: x stays, y and z flip.
const glm::dmat4 kCvFromXrView = glm::scale(glm::dmat4(1.0), glm::dvec3(1.0, -1.0, -1.0));

}  // namespace

bool eye_camera(const XrPose& pose, const XrFov& fov, std::uint32_t width, std::uint32_t height,
                const glm::dmat4& T_scene_space, Camera& out_camera) {
  const glm::dquat& q = pose.orientation;
  const double qn = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
  if (!finite3(pose.position) || !std::isfinite(qn) || qn < 1e-9 || width == 0 || height == 0) return false;
  constexpr double kMaxHalfAngle = 1.5707963267948966 - 1e-6;
  if (!(fov.angle_right > fov.angle_left) || !(fov.angle_up > fov.angle_down) ||
      std::abs(fov.angle_left) >= kMaxHalfAngle || std::abs(fov.angle_right) >= kMaxHalfAngle ||
      std::abs(fov.angle_up) >= kMaxHalfAngle || std::abs(fov.angle_down) >= kMaxHalfAngle)
    return false;

  const double tl = std::tan(fov.angle_left), tr = std::tan(fov.angle_right);
  const double tu = std::tan(fov.angle_up), td = std::tan(fov.angle_down);
  Camera cam = out_camera;
  cam.width = width;
  cam.height = height;
  cam.fx = double(width) / (tr - tl);
  cam.cx = -tl * cam.fx;               // the left edge (u = 0) is at x/z = tan(left)
  cam.fy = double(height) / (tu - td);
  cam.cy = tu * cam.fy;                // OpenCV v grows downward: the top edge is at -y/z = tan(up)

  glm::dmat4 T_space_xrview = glm::mat4_cast(q / qn);
  T_space_xrview[3] = glm::dvec4(pose.position, 1.0);
  const glm::dmat4 T_scene_cvcam = T_scene_space * T_space_xrview * kCvFromXrView;
  cam.world_to_camera = glm::inverse(T_scene_cvcam);
  out_camera = cam;
  return true;
}

namespace {
// The rotation taking +y to the unit vector u.
glm::dmat4 up_turn(const glm::dvec3& u) {
  const glm::dvec3 y(0.0, 1.0, 0.0);
  const glm::dvec3 axis = glm::cross(y, u);
  const double s = glm::length(axis);
  // Along +y: no turn; along -y (the 3DGS convention): the half turn about x, exactly.
  if (s < 1e-12) return u.y > 0.0 ? glm::dmat4(1.0) : glm::scale(glm::dmat4(1.0), glm::dvec3(1.0, -1.0, -1.0));
  return glm::rotate(glm::dmat4(1.0), std::atan2(s, glm::dot(y, u)), axis / s);
}
}  // namespace

glm::dmat4 scene_from_space(const glm::dvec3& scene_up, const std::optional<glm::dvec3>& face) {
  const double len = glm::length(scene_up);
  if (!std::isfinite(len) || len <= 0.0) return glm::dmat4(1.0);
  const glm::dmat4 turn = up_turn(scene_up / len);
  if (!face || !std::isfinite(face->x + face->y + face->z)) return turn;
  // The point in the turned room, and its heading about the room's up.
  const glm::dvec3 p = glm::transpose(glm::dmat3(turn)) * *face;
  const double h = std::hypot(p.x, p.z);
  if (!(h > 1e-9 * std::max(1.0, glm::length(p)))) return turn;
  // R_y(a) takes -z to (-sin a, 0, -cos a): equal to (p.x, 0, p.z) / h.
  return turn * glm::rotate(glm::dmat4(1.0), std::atan2(-p.x, -p.z), glm::dvec3(0.0, 1.0, 0.0));
}

XrPose pose_of_camera(const Camera& camera, const glm::dmat4& T_scene_space) {
  const glm::dmat4 T_scene_cvcam = glm::inverse(camera.world_to_camera);
  const glm::dmat4 T_space_xrview = glm::inverse(T_scene_space) * T_scene_cvcam * kCvFromXrView;
  XrPose pose;
  pose.orientation = glm::normalize(glm::quat_cast(glm::dmat3(T_space_xrview)));
  pose.position = glm::dvec3(T_space_xrview[3]);
  return pose;
}

}  // namespace gauss::xr
