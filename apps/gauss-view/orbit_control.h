#pragma once
// OrbitControl: gauss-view's orbit mode, driving the FlyCamera's pose (fly_camera.h). The
// pivot is `distance` ahead of the eye along the view direction; it is not stored but read
// from the pose every frame, so switching between orbit and fly never moves the view and a
// saved viewpoint or a fly move in orbit mode carries the pivot along.
//
// Controls (input_state.h): left drag orbits the pivot (yaw about the scene's up, pitch
// within FlyCamera::kMaxPitch), middle drag pans the view and the pivot with the cursor (the
// pivot's plane follows the pointer), the wheel moves toward / away from the pivot (x
// kZoomStep per step). Keys and right-mouse look still act as in fly mode, but the wheel zooms
// instead of setting the speed.
#include "fly_camera.h"
#include "gauss/engine/scene_framing.h"
#include "input_state.h"

namespace gauss::view {

class OrbitControl {
 public:
  // 0.005 rad/px: a 640-pixel drag turns ~180 degrees about the pivot.
  static constexpr double kOrbitRadiansPerPixel = 0.005;
  // One wheel step scales the distance by this (8 steps ~ x3).
  static constexpr double kZoomStep = 1.15;
  // The pivot stays at least this far ahead (relative to the framed distance): closer, the
  // zoom would stall.
  static constexpr double kMinDistanceShare = 1e-3;

  // Applies a frame's drags and wheel to `view`; `focal_px` is the view's focal length (a
  // pan moves the pivot's plane by exactly the cursor's motion). Returns whether the view
  // changed.
  bool update(FlyCamera& view, const InputState& in, double focal_px);

  // The pivot is this far ahead: the framing's distance (so F orbits the framed centre).
  void frame(const Framing& framing) { frame_at(framing.distance); }
  void frame_at(double distance);
  // Entering orbit from fly: the pivot is where the view ray passes nearest `centre` (the
  // framed centre), or, when that lies behind the eye, the framed distance ahead.
  void aim(const FlyCamera& view, const glm::dvec3& centre);

  double distance() const noexcept { return distance_; }
  glm::dvec3 pivot(const FlyCamera& view) const;

 private:
  double distance_{3.0};
  double framed_distance_{3.0};
};

}  // namespace gauss::view
