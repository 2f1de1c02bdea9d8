#pragma once
// FlyCamera: gauss-view's free-fly camera. A pose (position, yaw, pitch; no roll) in a
// world whose up is +y (the synthetic rooms: metres, floor at y = 0), turned into an
// OpenCV camera (x right, y down, z forward) for any view size.
//
// Controls (window.h InputState): W/S forward/back along the view direction, A/D
// sideways, E/Q along world up/down, Shift x kFastFactor, right mouse button held:
// look (kLookRadiansPerPixel), wheel: speed x kSpeedStep per step.
#include <cstdint>

#include <glm/vec3.hpp>

#include "gauss/engine/camera.h"
#include "options.h"
#include "window.h"

namespace gauss::view {

// Where the camera is and where it looks. yaw 0 looks along +z; positive yaw turns
// toward +x; positive pitch looks up.
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
  // Takes the position and view direction of `camera` (its roll is dropped).
  void set_from_camera(const Camera& camera);
  // The overview of a room-like box [lo, hi] (y up): from inside, high above one corner,
  // looking at the far lower centre (as SyntheticScene::overview_camera does).
  void frame_box(const glm::dvec3& lo, const glm::dvec3& hi);

  double speed() const noexcept { return speed_; }
  void set_speed(double metres_per_second);

 private:
  FlyPose pose_{};
  double speed_{1.5};
};

}  // namespace gauss::view
