// OrbitControl: drags and wheel -> FlyCamera pose about a pivot (contract in orbit_control.h).
#include "orbit_control.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

namespace gauss::view {

glm::dvec3 OrbitControl::pivot(const FlyCamera& view) const {
  return view.pose().position + view.forward() * distance_;
}

bool OrbitControl::update(FlyCamera& view, const InputState& in, double focal_px) {
  bool changed = false;
  const glm::dvec3 centre = pivot(view);
  if (in.dragging && (in.drag_dx != 0.0 || in.drag_dy != 0.0)) {
    // The scene turns with the cursor, as a globe grabbed at its front: dragging right swings
    // the eye to the left around the pivot (the view turns right: -yaw, see fly_camera.h),
    // dragging down lifts the eye (the view pitches down).
    FlyPose p = view.pose();
    p.yaw -= in.drag_dx * kOrbitRadiansPerPixel;
    p.pitch = std::clamp(p.pitch - in.drag_dy * kOrbitRadiansPerPixel, -FlyCamera::kMaxPitch, FlyCamera::kMaxPitch);
    view.set_pose(p);
    p.position = centre - view.forward() * distance_;
    view.set_pose(p);
    changed = true;
  } else if (in.panning && (in.drag_dx != 0.0 || in.drag_dy != 0.0)) {
    const glm::dvec3 f = view.forward();
    const glm::dvec3 right = glm::normalize(glm::cross(f, view.up()));
    const glm::dvec3 image_up = glm::cross(right, f);
    const double metres_per_px = distance_ / std::max(focal_px, 1e-9);
    FlyPose p = view.pose();
    p.position += (-in.drag_dx * right + in.drag_dy * image_up) * metres_per_px;
    view.set_pose(p);
    changed = true;
  }
  if (in.scroll != 0.0) {
    const double d = std::max(distance_ * std::pow(kZoomStep, -in.scroll), kMinDistanceShare * framed_distance_);
    FlyPose p = view.pose();
    p.position = pivot(view) - view.forward() * d;
    distance_ = d;
    view.set_pose(p);
    changed = true;
  }
  return changed;
}

void OrbitControl::frame_at(double distance) {
  framed_distance_ = std::isfinite(distance) ? std::max(distance, 1e-9) : 1.0;
  distance_ = framed_distance_;
}

void OrbitControl::aim(const FlyCamera& view, const glm::dvec3& centre) {
  const double along = glm::dot(centre - view.pose().position, view.forward());
  distance_ = std::isfinite(along) && along > kMinDistanceShare * framed_distance_ ? along : framed_distance_;
}

}  // namespace gauss::view
