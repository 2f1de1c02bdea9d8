// FlyCamera: input -> pose -> OpenCV camera (contract in fly_camera.h).
#include "fly_camera.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>

namespace gauss::view {
namespace {

constexpr glm::dvec3 kWorldUp{0.0, 1.0, 0.0};

glm::dvec3 forward_of(const FlyPose& p) {
  return {std::cos(p.pitch) * std::sin(p.yaw), std::sin(p.pitch), std::cos(p.pitch) * std::cos(p.yaw)};
}

}  // namespace

bool FlyCamera::update(const InputState& in, double dt_s) {
  const double dt = std::clamp(dt_s, 0.0, 0.1);
  bool changed = false;
  if (in.scroll != 0.0) {
    set_speed(speed_ * std::pow(kSpeedStep, in.scroll));
  }
  if (in.looking && (in.look_dx != 0.0 || in.look_dy != 0.0)) {
    // Cursor right turns right: with y up and z forward, the camera's right is -x, so yaw
    // (positive toward +x) decreases.
    pose_.yaw -= in.look_dx * kLookRadiansPerPixel;
    pose_.pitch = std::clamp(pose_.pitch - in.look_dy * kLookRadiansPerPixel, -kMaxPitch, kMaxPitch);
    changed = true;
  }
  const glm::dvec3 f = forward_of(pose_);
  const glm::dvec3 r = glm::normalize(glm::cross(f, kWorldUp));
  glm::dvec3 move{0.0};
  if (in.forward) move += f;
  if (in.back) move -= f;
  if (in.right) move += r;
  if (in.left) move -= r;
  if (in.up) move += kWorldUp;
  if (in.down) move -= kWorldUp;
  if (glm::dot(move, move) > 0.0) {
    const double v = speed_ * (in.fast ? kFastFactor : 1.0);
    pose_.position += glm::normalize(move) * (v * dt);
    changed = true;
  }
  return changed;
}

Camera FlyCamera::camera(std::uint32_t width, std::uint32_t height, double focal_px) const {
  Camera c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = focal_px;
  c.cx = 0.5 * width;
  c.cy = 0.5 * height;
  c.world_to_camera = glm::inverse(opencv_look_at(pose_.position, pose_.position + forward_of(pose_), kWorldUp));
  return c;
}

void FlyCamera::set_pose(const FlyPose& pose) {
  pose_ = pose;
  pose_.pitch = std::clamp(pose_.pitch, -kMaxPitch, kMaxPitch);
}

void FlyCamera::set_from_camera(const Camera& camera) {
  const glm::dmat4 c2w = glm::inverse(camera.world_to_camera);
  const glm::dvec3 f = glm::normalize(glm::dvec3(c2w[2]));
  FlyPose p;
  p.position = glm::dvec3(c2w[3]);
  p.yaw = std::atan2(f.x, f.z);
  p.pitch = std::asin(std::clamp(f.y, -1.0, 1.0));
  set_pose(p);
}

void FlyCamera::frame_box(const glm::dvec3& lo, const glm::dvec3& hi) {
  const glm::dvec3 size = hi - lo;
  const glm::dvec3 eye(lo.x + 0.12 * size.x, lo.y + 0.8 * size.y, lo.z + 0.12 * size.z);
  const glm::dvec3 target(lo.x + 0.5 * size.x, lo.y + 0.25 * size.y, lo.z + 0.5 * size.z);
  const glm::dvec3 d = target - eye;
  if (glm::dot(d, d) <= 0.0) return;  // a degenerate box: keep the pose
  const glm::dvec3 f = glm::normalize(d);
  FlyPose p;
  p.position = eye;
  p.yaw = std::atan2(f.x, f.z);
  p.pitch = std::asin(std::clamp(f.y, -1.0, 1.0));
  set_pose(p);
  // About 4 s to cross the box.
  set_speed(std::max({size.x, size.z, 1.0}) / 4.0);
}

void FlyCamera::set_speed(double metres_per_second) { speed_ = std::clamp(metres_per_second, kMinSpeed, kMaxSpeed); }

}  // namespace gauss::view
