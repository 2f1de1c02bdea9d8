// FlyCamera: input -> pose -> OpenCV camera (contract in fly_camera.h).
#include "fly_camera.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>

namespace gauss::view {
namespace {

// The horizontal frame of yaw about `up`: yaw 0 looks along `front`, +yaw toward `left`.
struct YawFrame {
  glm::dvec3 front, left;
};

YawFrame yaw_frame(const glm::dvec3& up) {
  const glm::dvec3 front = front_direction(up);
  return {front, glm::cross(up, front)};
}

glm::dvec3 forward_of(const FlyPose& p, const glm::dvec3& up) {
  const YawFrame h = yaw_frame(up);
  return std::cos(p.pitch) * (std::sin(p.yaw) * h.left + std::cos(p.yaw) * h.front) + std::sin(p.pitch) * up;
}

}  // namespace

bool FlyCamera::update(const InputState& in, double dt_s) {
  const double dt = std::clamp(dt_s, 0.0, 0.1);
  bool changed = false;
  if (in.scroll != 0.0) {
    set_speed(speed_ * std::pow(kSpeedStep, in.scroll));
  }
  if (in.looking && (in.look_dx != 0.0 || in.look_dy != 0.0)) {
    // Cursor right turns right: +yaw turns left.
    pose_.yaw -= in.look_dx * kLookRadiansPerPixel;
    pose_.pitch = std::clamp(pose_.pitch - in.look_dy * kLookRadiansPerPixel, -kMaxPitch, kMaxPitch);
    changed = true;
  }
  const glm::dvec3 f = forward_of(pose_, up_);
  const glm::dvec3 r = glm::normalize(glm::cross(f, up_));
  glm::dvec3 move{0.0};
  if (in.forward) move += f;
  if (in.back) move -= f;
  if (in.right) move += r;
  if (in.left) move -= r;
  if (in.up) move += up_;
  if (in.down) move -= up_;
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
  c.far_plane = far_;
  c.world_to_camera = glm::inverse(opencv_look_at(pose_.position, pose_.position + forward_of(pose_, up_), up_));
  return c;
}

void FlyCamera::set_pose(const FlyPose& pose) {
  pose_ = pose;
  pose_.pitch = std::clamp(pose_.pitch, -kMaxPitch, kMaxPitch);
}

glm::dvec3 FlyCamera::forward() const { return forward_of(pose_, up_); }

void FlyCamera::set_up(const glm::dvec3& up) {
  const double len = glm::length(up);
  if (!std::isfinite(len) || len < 1e-12) return;
  const glm::dvec3 f = forward();
  up_ = up / len;
  look(pose_.position, f);
}

void FlyCamera::look(const glm::dvec3& position, const glm::dvec3& direction) {
  const double len = glm::length(direction);
  FlyPose p = pose_;
  p.position = position;
  if (std::isfinite(len) && len > 0.0) {
    const glm::dvec3 f = direction / len;
    const YawFrame h = yaw_frame(up_);
    p.yaw = std::atan2(glm::dot(f, h.left), glm::dot(f, h.front));
    p.pitch = std::asin(std::clamp(glm::dot(f, up_), -1.0, 1.0));
  }
  set_pose(p);
}

void FlyCamera::set_from_camera(const Camera& camera) {
  const glm::dmat4 c2w = glm::inverse(camera.world_to_camera);
  look(glm::dvec3(c2w[3]), glm::dvec3(c2w[2]));
}

void FlyCamera::frame(const Framing& fr) {
  up_ = fr.up;
  look(fr.eye, fr.target - fr.eye);
  const glm::dvec3 size = fr.hi - fr.lo;
  set_speed(std::max({size.x, size.y, size.z}) / 4.0);
  far_ = std::max(1000.0, 2.0 * (fr.distance + glm::length(size)));
}

void FlyCamera::set_speed(double metres_per_second) { speed_ = std::clamp(metres_per_second, kMinSpeed, kMaxSpeed); }

}  // namespace gauss::view
