#include "gauss/xr/xr_pose.h"

#include "gauss/xr/xr_controls.h"

#include <cmath>
#include <limits>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/matrix.hpp>
#include <gtest/gtest.h>

namespace gauss::xr {
namespace {

constexpr double kPi = 3.14159265358979323846;

glm::dvec2 project(const Camera& c, const glm::dvec3& world) {
  const glm::dvec4 t = c.world_to_camera * glm::dvec4(world, 1.0);
  return {c.fx * t.x / t.z + c.cx, c.fy * t.y / t.z + c.cy};
}

TEST(XrPose, IdentityPoseLooksDownMinusZWithYUp) {
  Camera cam;
  const XrFov fov{-kPi / 4, kPi / 4, kPi / 4, -kPi / 4};
  ASSERT_TRUE(eye_camera(XrPose{}, fov, 200, 100, glm::dmat4(1.0), cam));
  EXPECT_NEAR(cam.fx, 100.0, 1e-9);   // 200 px over tan(45) - tan(-45) = 2
  EXPECT_NEAR(cam.fy, 50.0, 1e-9);
  EXPECT_NEAR(cam.cx, 100.0, 1e-9);
  EXPECT_NEAR(cam.cy, 50.0, 1e-9);
  // A point straight ahead in OpenXR (-z) lands on the principal point, in front of the camera.
  const glm::dvec4 ahead = cam.world_to_camera * glm::dvec4(0, 0, -2, 1);
  EXPECT_NEAR(ahead.z, 2.0, 1e-12);
  const glm::dvec2 p = project(cam, {0, 0, -2});
  EXPECT_NEAR(p.x, 100.0, 1e-9);
  EXPECT_NEAR(p.y, 50.0, 1e-9);
  // OpenXR up (+y) is image up (smaller v); OpenXR right (+x) is image right.
  EXPECT_LT(project(cam, {0, 0.5, -2}).y, 50.0);
  EXPECT_GT(project(cam, {0.5, 0, -2}).x, 100.0);
}

// A scene whose up is not the room's (a 3DGS capture is y down) is turned so that its up is
// the headset's: what is "up" in the scene is image-up for a level head, and straight ahead
// stays ahead (the turn is about the room's horizontal).
TEST(XrPose, SceneFromSpaceTurnsTheScenesUpToTheRoomsUp) {
  const XrFov fov{-kPi / 4, kPi / 4, kPi / 4, -kPi / 4};
  for (const glm::dvec3 up : {glm::dvec3(0, -1, 0), glm::dvec3(0, 0, 1), glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0),
                              glm::normalize(glm::dvec3(0.1, -0.98, 0.2))}) {
    const glm::dmat4 t = scene_from_space(up);
    // A proper rotation about the origin taking the room's +y to the scene's up.
    EXPECT_NEAR(glm::determinant(glm::dmat3(t)), 1.0, 1e-12);
    EXPECT_EQ(glm::dvec3(t[3]), glm::dvec3(0.0));
    EXPECT_LT(glm::length(glm::dmat3(t) * glm::dvec3(0, 1, 0) - up), 1e-12) << up.x << " " << up.y << " " << up.z;
    // A level head: the scene's up projects above the principal point.
    Camera cam;
    ASSERT_TRUE(eye_camera(XrPose{}, fov, 200, 100, t, cam));
    const glm::dvec3 ahead = glm::dmat3(t) * glm::dvec3(0, 0, -2);
    EXPECT_NEAR(project(cam, ahead).y, 50.0, 1e-9);
    EXPECT_LT(project(cam, ahead + 0.5 * up).y, 50.0);
  }
  // -y is the half turn about x exactly (the turn half_turn_about_x makes of a capture).
  const glm::dmat4 half = scene_from_space({0, -1, 0});
  EXPECT_EQ(glm::dmat3(half), glm::dmat3(glm::dvec3(1, 0, 0), glm::dvec3(0, -1, 0), glm::dvec3(0, 0, -1)));
  // Facing a subject: turned about the room's up only, the subject straight ahead of a level head.
  for (const glm::dvec3 up : {glm::dvec3(0, -1, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1)}) {
    const glm::dvec3 subject(0.7, 0.4, -2.1);
    const glm::dmat4 t = scene_from_space(up, subject);
    EXPECT_LT(glm::length(glm::dmat3(t) * glm::dvec3(0, 1, 0) - up), 1e-12);
    EXPECT_NEAR(glm::determinant(glm::dmat3(t)), 1.0, 1e-12);
    Camera cam;
    ASSERT_TRUE(eye_camera(XrPose{}, fov, 200, 100, t, cam));
    EXPECT_GT((cam.world_to_camera * glm::dvec4(subject, 1.0)).z, 0.0) << "in front";
    EXPECT_NEAR(project(cam, subject).x, 100.0, 1e-9) << "straight ahead";
  }
  // A subject right above the origin, or not finite, keeps the heading.
  EXPECT_EQ(scene_from_space({0, -1, 0}, glm::dvec3(0, -3, 0)), half);
  EXPECT_EQ(scene_from_space({0, -1, 0}, glm::dvec3(std::numeric_limits<double>::infinity(), 0, 0)), half);
  // No usable up: the identity.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(scene_from_space({0, 0, 0}), glm::dmat4(1.0));
  EXPECT_EQ(scene_from_space({nan, 1, 0}), glm::dmat4(1.0));
  EXPECT_EQ(scene_from_space({0, 5, 0}), glm::dmat4(1.0));
}

// The controller's ray is in the scene the eyes see: turned and moved with it.
TEST(XrPose, TheAimRayFollowsTheScenesPlacement) {
  XrPose aim;
  aim.position = {0.1, 1.2, -0.3};
  glm::dvec3 origin, direction;
  aim_ray(aim, glm::dmat4(1.0), origin, direction);
  EXPECT_EQ(origin, aim.position);
  EXPECT_LT(glm::length(direction - glm::dvec3(0, 0, -1)), 1e-12);
  const glm::dmat4 t = glm::translate(glm::dmat4(1.0), {2.0, 0.0, 0.0}) * scene_from_space({0, -1, 0});
  aim_ray(aim, t, origin, direction);
  EXPECT_LT(glm::length(origin - glm::dvec3(2.1, -1.2, 0.3)), 1e-12);
  EXPECT_LT(glm::length(direction - glm::dvec3(0, 0, 1)), 1e-12);
}

TEST(XrPose, AsymmetricFovMovesPrincipalPoint) {
  Camera cam;
  const XrFov fov{-0.9, 0.7, 0.8, -0.85};  // a typical headset eye: wider toward the nose
  ASSERT_TRUE(eye_camera(XrPose{}, fov, 1000, 1000, glm::dmat4(1.0), cam));
  // The frustum's edges project to the image borders.
  EXPECT_NEAR(project(cam, {std::tan(-0.9), 0, -1}).x, 0.0, 1e-9);
  EXPECT_NEAR(project(cam, {std::tan(0.7), 0, -1}).x, 1000.0, 1e-9);
  EXPECT_NEAR(project(cam, {0, std::tan(0.8), -1}).y, 0.0, 1e-9);
  EXPECT_NEAR(project(cam, {0, std::tan(-0.85), -1}).y, 1000.0, 1e-9);
}

TEST(XrPose, RotatedTranslatedPoseRoundTrips) {
  XrPose pose;
  pose.orientation = glm::angleAxis(0.7, glm::normalize(glm::dvec3(0.2, 1.0, -0.3)));
  pose.position = {1.5, 1.6, -0.4};
  const glm::dmat4 T_scene_space = glm::rotate(glm::translate(glm::dmat4(1.0), {3, 0, 1}), 0.3, glm::dvec3(0, 1, 0));
  Camera cam;
  ASSERT_TRUE(eye_camera(pose, XrFov{-0.8, 0.8, 0.8, -0.8}, 64, 64, T_scene_space, cam));
  // The world_to_camera stays rigid.
  const glm::dmat3 R(cam.world_to_camera);
  const glm::dmat3 RtR = glm::transpose(R) * R;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(RtR[i][j], i == j ? 1.0 : 0.0, 1e-12);
  const XrPose back = pose_of_camera(cam, T_scene_space);
  EXPECT_NEAR(glm::length(back.position - pose.position), 0.0, 1e-12);
  EXPECT_NEAR(std::abs(glm::dot(back.orientation, pose.orientation)), 1.0, 1e-12);
}

TEST(XrPose, RejectsBadInputWithoutTouchingTheCamera) {
  Camera cam;
  cam.fx = 123.0;
  const XrFov good{-0.8, 0.8, 0.8, -0.8};
  XrPose nan_pose;
  nan_pose.position.x = std::nan("");
  EXPECT_FALSE(eye_camera(nan_pose, good, 64, 64, glm::dmat4(1.0), cam));
  XrPose zero_q;
  zero_q.orientation = glm::dquat(0, 0, 0, 0);
  EXPECT_FALSE(eye_camera(zero_q, good, 64, 64, glm::dmat4(1.0), cam));
  EXPECT_FALSE(eye_camera(XrPose{}, XrFov{0.8, -0.8, 0.8, -0.8}, 64, 64, glm::dmat4(1.0), cam));
  EXPECT_FALSE(eye_camera(XrPose{}, XrFov{-1.6, 0.8, 0.8, -0.8}, 64, 64, glm::dmat4(1.0), cam));
  EXPECT_FALSE(eye_camera(XrPose{}, good, 0, 64, glm::dmat4(1.0), cam));
  EXPECT_EQ(cam.fx, 123.0);
}

}  // namespace
}  // namespace gauss::xr
