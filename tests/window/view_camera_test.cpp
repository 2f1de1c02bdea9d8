// gauss-view's camera controls without a window (apps/gauss-view fly_camera.h,
// orbit_control.h): the window's default view is the library's framed camera, a new up
// or a switch between fly and orbit does not move the view, orbit turns about and zooms
// toward a fixed pivot, pan moves the pivot's plane with the cursor, E/Q follow the up.
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <gtest/gtest.h>

#include "fly_camera.h"
#include "gauss/engine/scene_framing.h"
#include "orbit_control.h"

namespace gauss::view {
namespace {

constexpr double kFocal = 228.5;

FramingLens lens() {
  FramingLens l;
  l.width = 320;
  l.height = 240;
  l.fx = l.fy = kFocal;
  return l;
}

void expect_same_view(const Camera& a, const Camera& b, double tol = 1e-9) {
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(a.world_to_camera[i][j], b.world_to_camera[i][j], tol) << i << "," << j;
}

Framing guitar_like() { return frame_bounds({-0.5, -4.1, -0.35}, {0.6, 0.0, 0.8}, {0, -1, 0}, lens()); }

TEST(ViewCamera, FramedFlyCameraIsTheLibrarysCamera) {
  FlyCamera fly;
  const Framing fr = guitar_like();
  fly.frame(fr);
  expect_same_view(fly.camera(320, 240, kFocal), framed_camera(fr, lens()));
  EXPECT_EQ(fly.up(), glm::dvec3(0, -1, 0));
  // E goes along the scene's up (-y here), not +y.
  InputState in;
  in.up = true;
  const glm::dvec3 before = fly.pose().position;
  ASSERT_TRUE(fly.update(in, 0.05));
  const glm::dvec3 step = fly.pose().position - before;
  EXPECT_GT(glm::dot(glm::normalize(step), glm::dvec3(0, -1, 0)), 0.999);
}

// The preset views reach the fly camera as the library frames them: the top view's
// elevation (kTopElevation) is within the fly camera's pitch limit, so nothing is clamped.
TEST(ViewCamera, PresetViewsAreTheLibrarysCameras) {
  static_assert(kTopElevation < FlyCamera::kMaxPitch);
  for (const ViewPreset preset : {ViewPreset::Front, ViewPreset::Side, ViewPreset::Top}) {
    FlyCamera fly;
    const Framing fr = frame_preset({-0.5, -4.1, -0.35}, {0.6, 0.0, 0.8}, {0, -1, 0}, lens(), preset);
    fly.frame(fr);
    expect_same_view(fly.camera(320, 240, kFocal), framed_camera(fr, lens()));
  }
}

TEST(ViewCamera, NewUpKeepsPositionAndDirection) {
  FlyCamera fly;
  fly.frame(guitar_like());
  const glm::dvec3 pos = fly.pose().position, fwd = fly.forward();
  fly.set_up({0, 0, 1});
  EXPECT_EQ(fly.pose().position, pos);
  EXPECT_NEAR(glm::length(fly.forward() - fwd), 0.0, 1e-9);
  const Camera c = fly.camera(320, 240, kFocal);
  const glm::dvec3 image_up = -glm::dvec3(glm::inverse(c.world_to_camera)[1]);
  EXPECT_GT(glm::dot(image_up, glm::dvec3(0, 0, 1)), 0.0) << "the image rolls to the new up";
  fly.set_up({0, 0, 0});  // ignored
  EXPECT_EQ(fly.up(), glm::dvec3(0, 0, 1));
}

TEST(ViewCamera, OrbitTurnsAboutAFixedPivotAndSwitchingDoesNotJump) {
  FlyCamera fly;
  OrbitControl orbit;
  const Framing fr = guitar_like();
  fly.frame(fr);
  orbit.frame(fr);
  EXPECT_NEAR(glm::length(orbit.pivot(fly) - fr.target), 0.0, 1e-9) << "F orbits the framed centre";
  const Camera before = fly.camera(320, 240, kFocal);
  orbit.aim(fly, fr.target);  // entering orbit from fly
  expect_same_view(fly.camera(320, 240, kFocal), before);
  EXPECT_NEAR(orbit.distance(), fr.distance, 1e-9);

  InputState drag;
  drag.dragging = true;
  drag.drag_dx = 120.0;
  drag.drag_dy = -40.0;
  ASSERT_TRUE(orbit.update(fly, drag, kFocal));
  EXPECT_NEAR(glm::length(orbit.pivot(fly) - fr.target), 0.0, 1e-9);
  EXPECT_NEAR(glm::length(fly.pose().position - fr.target), fr.distance, 1e-9);
  EXPECT_GT(glm::length(fly.pose().position - fr.eye), 0.1) << "the eye moved round";
  EXPECT_NEAR(fly.pose().yaw, -120.0 * OrbitControl::kOrbitRadiansPerPixel, 1e-9);

  InputState wheel;
  wheel.scroll = 2.0;  // toward the pivot
  ASSERT_TRUE(orbit.update(fly, wheel, kFocal));
  EXPECT_NEAR(orbit.distance(), fr.distance / (OrbitControl::kZoomStep * OrbitControl::kZoomStep), 1e-9);
  EXPECT_NEAR(glm::length(orbit.pivot(fly) - fr.target), 0.0, 1e-9);

  // Pan: the pivot (at the pivot's depth) moves with the cursor, the direction stays.
  const glm::dvec3 fwd = fly.forward(), pivot0 = orbit.pivot(fly);
  const Camera c0 = fly.camera(320, 240, kFocal);
  InputState pan;
  pan.panning = true;
  pan.drag_dx = 30.0;
  pan.drag_dy = 10.0;
  ASSERT_TRUE(orbit.update(fly, pan, kFocal));
  EXPECT_NEAR(glm::length(fly.forward() - fwd), 0.0, 1e-12);
  // The old pivot, seen from the panned camera, sits where the cursor went.
  const Camera c1 = fly.camera(320, 240, kFocal);
  const glm::dvec4 q0 = c0.world_to_camera * glm::dvec4(pivot0, 1.0), q1 = c1.world_to_camera * glm::dvec4(pivot0, 1.0);
  EXPECT_NEAR(kFocal * q1.x / q1.z - kFocal * q0.x / q0.z, 30.0, 1e-6);
  EXPECT_NEAR(kFocal * q1.y / q1.z - kFocal * q0.y / q0.z, 10.0, 1e-6);

  // Leaving orbit: the fly camera is the view; nothing to do, nothing moves.
  // Entering again with the framed centre behind the eye keeps the framed distance.
  FlyCamera away;
  away.look(fr.target + glm::dvec3(0, 0, 5), {0, 0, 1});
  orbit.aim(away, fr.target);
  EXPECT_NEAR(orbit.distance(), fr.distance, 1e-9);
}

TEST(ViewCamera, CursorMotionWithoutADragDoesNothing) {
  FlyCamera fly;
  OrbitControl orbit;
  fly.frame(guitar_like());
  InputState idle;
  idle.drag_dx = 50.0;  // motion without a button held
  EXPECT_FALSE(orbit.update(fly, idle, kFocal));
}

}  // namespace
}  // namespace gauss::view
