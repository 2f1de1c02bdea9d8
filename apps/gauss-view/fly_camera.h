#pragma once
// FlyCamera: gauss-view's free-fly camera. A pose (position, yaw, pitch; no roll) about the
// scene's up (set_up: +y for the synthetic rooms, -y for 3DGS/COLMAP scenes, whatever a
// trainer's cameras say), turned into an OpenCV camera (x right, y down, z forward) for any
// view size; the image's up always leans toward the scene's up.
//
// Controls (input_state.h): W/S forward/back along the view direction, A/D
// sideways, E/Q along the scene's up/down, Shift x kFastFactor, right mouse button held:
// look (kLookRadiansPerPixel), wheel: speed x kSpeedStep per step.
#include <cstdint>

#include <glm/vec3.hpp>

#include "gauss/engine/camera.h"
#include "gauss/engine/scene_framing.h"
#include "input_state.h"

namespace gauss::view {

// Where the camera is and where it looks, relative to the camera's up: yaw 0 looks along
// front_direction(up) (scene_framing.h; -z for up +y), positive yaw turns to the left,
// positive pitch looks up.
struct FlyPose {
  glm::dvec3 position{0.0, 1.6, 0.0};
  double yaw{0.0};    // radians
  double pitch{0.0};  // radians, kept within +-kMaxPitch
};

class FlyCamera {
 public:
  // One wheel step changes the speed by this factor (8 steps ~ x4).
  static constexpr double kSpeedStep = 1.2;
  static constexpr double kMinSpeed = 0.05;  // m/s
  static constexpr double kMaxSpeed = 50.0;  // m/s
  static constexpr double kFastFactor = 4.0;
  // 0.003 rad/px: a 1280-pixel mouse sweep turns ~220 degrees.
  static constexpr double kLookRadiansPerPixel = 0.003;
  // Just short of straight up/down, where yaw and the image's up are undefined.
  static constexpr double kMaxPitch = 1.55;

  // Moves and turns by one display frame's input over `dt_s` seconds (clamped to 0.1 s so
  // a stall does not throw the camera across the scene). Returns whether anything changed.
  bool update(const InputState& in, double dt_s);

  // The OpenCV camera of this pose: `width` x `height` pixels, focal length `focal_px`
  // (fx = fy), principal point at the centre.
  Camera camera(std::uint32_t width, std::uint32_t height, double focal_px) const;

  const FlyPose& pose() const noexcept { return pose_; }
  void set_pose(const FlyPose& pose);
  // The view direction (unit) and the up the pose is relative to.
  glm::dvec3 forward() const;
  const glm::dvec3& up() const noexcept { return up_; }
  // Turns the world about: the position and view direction stay (the direction's pitch is
  // clamped to +-kMaxPitch about the new up); the image rolls to the new up. A zero or
  // non-finite up is ignored.
  void set_up(const glm::dvec3& up);
  // Looks from `position` along `direction` (non-zero; a zero direction keeps the view).
  void look(const glm::dvec3& position, const glm::dvec3& direction);
  // Takes the position and view direction of `camera` (its roll is dropped).
  void set_from_camera(const Camera& camera);
  // Takes a framing (scene_framing.h): its up, eye and view of its target; the speed
  // crosses the framed box in about 4 s; the far plane reaches past it.
  void frame(const Framing& framing);

  double speed() const noexcept { return speed_; }
  void set_speed(double metres_per_second);

 private:
  FlyPose pose_{};
  double speed_{1.5};
  glm::dvec3 up_{0.0, 1.0, 0.0};
  double far_{1000.0};
};

}  // namespace gauss::view
