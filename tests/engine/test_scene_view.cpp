// The view a host announces for its scene (scene_view.h): a capture's up and robust subject
// box, the synthetic room's inside view, degenerate input kept finite, and the framing a
// client makes of it equal to a local viewer's of the same Gaussians. The RGB-D capture's view
// from its cameras uses the shared SUN3D frames (../shared/data/rgbd, skipped when absent).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "gauss/engine/rgbd_scene.h"
#include "gauss/engine/rgbd_source.h"
#include "gauss/engine/scene_up.h"
#include "gauss/engine/scene_view.h"
#include "test_data.h"

namespace gauss {
namespace {

std::vector<Gaussian> spread_scene() {
  // A 2 x 1 x 3 block of solid Gaussians plus faint floaters far away.
  std::vector<Gaussian> gs;
  for (int i = 0; i < 400; ++i) {
    Gaussian g;
    g.position = {2.0f * float(i % 7) / 6.0f, float(i % 5) / 4.0f, 3.0f * float(i % 11) / 10.0f};
    g.opacity_logit = 4.0f;
    gs.push_back(g);
  }
  for (int i = 0; i < 40; ++i) {
    Gaussian g;
    g.position = {100.0f + float(i), -50.0f, 80.0f};
    g.opacity_logit = -12.0f;
    gs.push_back(g);
  }
  return gs;
}

TEST(SceneView, ACaptureIsFramedFromOutsideItsRobustBoxUprightForItsUp) {
  const auto gs = spread_scene();
  const msg::SceneView v = capture_view(gs, glm::dvec3(0.0, -2.0, 0.0), glm::dvec3(0.5, 0.5, -4.0));
  EXPECT_EQ(v.up, glm::vec3(0.0f, -1.0f, 0.0f));
  EXPECT_EQ(v.flags, msg::kViewSeenFrom);
  EXPECT_EQ(v.seen_from, glm::vec3(0.5f, 0.5f, -4.0f));
  const RobustBounds box = robust_bounds(gs, BoundsWeighting::Opacity);
  EXPECT_EQ(v.subject_min, glm::vec3(box.lo));
  EXPECT_EQ(v.subject_max, glm::vec3(box.hi));
  EXPECT_LT(v.subject_max.x, 10.0f) << "the faint floaters are left out";

  // A client framing it frames what a local viewer of the same Gaussians frames.
  FramingLens lens;
  const Framing client = frame_scene_view(v, lens, ViewPreset::Side);
  const Framing local = frame_preset(box.lo, box.hi, glm::dvec3(0.0, -1.0, 0.0), lens, ViewPreset::Side,
                                     glm::dvec3(0.5, 0.5, -4.0));
  EXPECT_LT(glm::length(client.eye - local.eye), 1e-5);
  EXPECT_LT(glm::length(client.target - local.target), 1e-5);
  EXPECT_EQ(client.up, local.up);
}

TEST(SceneView, DegenerateInputGivesAFiniteView) {
  const auto gs = spread_scene();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const glm::dvec3 up : {glm::dvec3(0.0), glm::dvec3(nan, 1.0, 0.0), glm::dvec3(1e300, 1e300, 0.0)}) {
    const msg::SceneView v = capture_view(gs, up);
    EXPECT_EQ(v.up, glm::vec3(0.0f, 1.0f, 0.0f));
    EXPECT_EQ(v.flags, 0);
  }
  // A seen-from that is not finite (or not a float) is not announced.
  EXPECT_EQ(capture_view(gs, glm::dvec3(0, 1, 0), glm::dvec3(nan, 0.0, 0.0)).flags, 0);
  EXPECT_EQ(capture_view(gs, glm::dvec3(0, 1, 0), glm::dvec3(1e300, 0.0, 0.0)).flags, 0);
  // No Gaussians, or none with a finite centre: the unit box.
  std::vector<Gaussian> bad(3);
  for (Gaussian& g : bad) g.position = glm::vec3(std::numeric_limits<float>::infinity());
  for (const auto& set : {std::vector<Gaussian>{}, bad}) {
    const msg::SceneView v = capture_view(set, glm::dvec3(0, 0, 1));
    EXPECT_EQ(v.subject_min, glm::vec3(-1.0f));
    EXPECT_EQ(v.subject_max, glm::vec3(1.0f));
    const Framing f = frame_scene_view(v, FramingLens{});
    EXPECT_TRUE(std::isfinite(f.eye.x + f.eye.y + f.eye.z));
  }
  // view_up of a hand-made view that is not unit (a client never gets one: the wire refuses).
  msg::SceneView odd;
  odd.up = {0.0f, 0.0f, 0.0f};
  EXPECT_EQ(view_up(odd), glm::dvec3(0.0, 1.0, 0.0));
  odd.up = {0.0f, 0.0f, -3.0f};
  EXPECT_EQ(view_up(odd), glm::dvec3(0.0, 0.0, -1.0));
}

TEST(SceneView, TheSyntheticRoomIsSeenFromInside) {
  const msg::SceneView v = room_view({-3.0f, 0.0f, -4.0f}, {3.0f, 2.8f, 4.0f});
  EXPECT_EQ(v.flags, msg::kViewInside);
  EXPECT_EQ(v.up, glm::vec3(0.0f, 1.0f, 0.0f));
  EXPECT_EQ(v.subject_min, glm::vec3(-3.0f, 0.0f, -4.0f));
  // Its first view stands inside, high above a corner, looking down into the room.
  const Framing f = frame_scene_view(v, FramingLens{});
  for (int a = 0; a < 3; ++a) {
    EXPECT_GT(f.eye[a], double(v.subject_min[a]));
    EXPECT_LT(f.eye[a], double(v.subject_max[a]));
  }
  EXPECT_LT(f.target.y, f.eye.y);
  EXPECT_EQ(f.up, glm::dvec3(0.0, 1.0, 0.0));
  // The other presets, another up, or a room without floor area: from outside, as frame_preset.
  auto outside = [&](const msg::SceneView& w, ViewPreset preset) {
    const Framing g = frame_scene_view(w, FramingLens{}, preset);
    const Framing want = frame_preset(glm::dvec3(w.subject_min), glm::dvec3(w.subject_max), view_up(w), FramingLens{},
                                      preset);
    EXPECT_LT(glm::length(g.eye - want.eye), 1e-9);
    EXPECT_TRUE(std::isfinite(g.eye.x + g.eye.y + g.eye.z));
  };
  outside(v, ViewPreset::Top);
  msg::SceneView turned = v;
  turned.up = {0.0f, 0.0f, 1.0f};
  outside(turned, ViewPreset::Front);
  msg::SceneView flat = v;
  flat.subject_max.x = flat.subject_min.x;
  outside(flat, ViewPreset::Front);
  // The widest box the wire accepts still frames to a finite camera.
  msg::SceneView huge = v;
  huge.flags = 0;
  huge.subject_min = glm::vec3(-3e38f);
  huge.subject_max = glm::vec3(3e38f);
  outside(huge, ViewPreset::Front);
}

// OpenCV camera axes for a heading (radians about `up`, 0 looking along `front`), a pitch
// (down positive) and a roll, in a world whose up is `up`.
CameraAxes camera_axes(const glm::dvec3& up, const glm::dvec3& front, double heading, double pitch, double roll) {
  const glm::dvec3 side = glm::cross(front, up);  // right of a camera looking along front
  const glm::dvec3 f = std::cos(heading) * front + std::sin(heading) * side;
  const glm::dvec3 r0 = glm::cross(f, up);
  const glm::dvec3 fwd = std::cos(pitch) * f - std::sin(pitch) * up;
  const glm::dvec3 down0 = glm::cross(fwd, r0);  // OpenCV: down = forward x right
  const glm::dvec3 right = std::cos(roll) * r0 + std::sin(roll) * down0;
  const glm::dvec3 down = glm::cross(fwd, right);
  return {right, down};
}

double degrees_between(const glm::dvec3& a, const glm::dvec3& b) {
  return std::acos(std::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0, 1.0)) * 180.0 / 3.14159265358979;
}

TEST(SceneUp, ACapturesUpIsLevelWithItsCamerasRightAxesNotTiltedByTheirPitch) {
  const glm::dvec3 up(0.0, 0.0, 1.0), front(1.0, 0.0, 0.0);
  // A 60 degree arc of cameras, all looking 30 degrees down: the mean image-up leans 15
  // degrees toward the arc's middle; the right axes' plane is level.
  std::vector<CameraAxes> arc;
  glm::dvec3 mean(0.0);
  for (int i = 0; i <= 6; ++i) {
    arc.push_back(camera_axes(up, front, (i - 3) * 10.0 * 3.14159265358979 / 180.0, 0.52, 0.0));
    mean -= arc.back().down;
  }
  EXPECT_GT(degrees_between(mean, up), 10.0);
  auto u = capture_up(arc);
  ASSERT_TRUE(u.ok()) << u.message();
  EXPECT_LT(degrees_between(*u, up), 1e-6);
  // One heading, rolled 4 degrees and pitched 20: level with the right axis (the roll goes),
  // the pitch's lean cannot be told from one heading and stays.
  const std::vector<CameraAxes> one = {camera_axes(up, front, 0.0, 0.35, 0.07), camera_axes(up, front, 0.0, 0.35, 0.07)};
  u = capture_up(one);
  ASSERT_TRUE(u.ok()) << u.message();
  EXPECT_LT(std::abs(glm::dot(*u, glm::normalize(one[0].right))), 1e-9);
  EXPECT_LT(degrees_between(*u, -one[0].down), 5.0);
  // Portrait and landscape shots mixed: the right axes span a vertical plane, whose normal is
  // level; the mean image-up stands.
  std::vector<CameraAxes> mixed;
  for (int i = 0; i < 4; ++i) mixed.push_back(camera_axes(up, front, 0.3 * i, 0.0, i % 2 ? 1.5707963 : 0.0));
  glm::dvec3 mixed_mean(0.0);
  for (const auto& c : mixed) mixed_mean -= c.down;
  u = capture_up(mixed);
  ASSERT_TRUE(u.ok()) << u.message();
  EXPECT_LT(degrees_between(*u, mixed_mean), 1e-6);
  // Ups that cancel, or nothing finite: no up.
  EXPECT_FALSE(capture_up(std::vector<CameraAxes>{{{1, 0, 0}, {0, 1, 0}}, {{1, 0, 0}, {0, -1, 0}}}).ok());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(capture_up(std::vector<CameraAxes>{{{nan, 0, 0}, {0, 1, 0}}}).ok());
  EXPECT_FALSE(capture_up(std::vector<CameraAxes>{}).ok());
  // A non-finite camera among good ones is left out.
  arc.push_back({{nan, 0, 0}, {0, 0, 1}});
  u = capture_up(arc);
  ASSERT_TRUE(u.ok()) << u.message();
  EXPECT_LT(degrees_between(*u, up), 1e-6);
}

TEST(SceneView, AnRgbdCapturesUpIsItsCamerasUp) {
  const auto dir = test::data_file("rgbd/sun3d_studyroom");
  if (!dir) GTEST_SKIP() << "../shared/data/rgbd/sun3d_studyroom absent (set GAUSS_DATA_DIR)";
  const std::filesystem::path folder = *dir;
  RgbdSceneOptions o;
  o.seed.stride = 16;
  o.surface.reset();
  auto fit = fit_capture(folder, o);
  ASSERT_TRUE(fit.ok()) << fit.message();
  // The cameras' up from their poses, level with each camera's right axis: the frames look
  // down at a desk, which tilts their mean image-up.
  auto frames = RgbdFolderSource::open(folder);
  ASSERT_TRUE(frames.ok()) << frames.message();
  std::vector<CameraAxes> axes;
  glm::dvec3 mean(0.0);
  for (std::size_t i = 0; i < frames->frame_count(); ++i) {
    auto p = frames->frame_pose(i);
    ASSERT_TRUE(p.ok()) << p.message();
    axes.push_back({glm::dvec3((*p)[0]), glm::dvec3((*p)[1])});
    mean -= glm::dvec3((*p)[1]);
  }
  const auto up = capture_up(axes);
  ASSERT_TRUE(up.ok()) << up.message();
  EXPECT_LT(glm::length(glm::dvec3(fit->view.up) - *up), 1e-6);
  for (const CameraAxes& a : axes) EXPECT_LT(std::abs(glm::dot(*up, a.right)), 0.08) << "level with every right axis";
  EXPECT_GT(degrees_between(*up, mean), 5.0) << "the frames' pitch tilts their mean image-up (10.4 degrees here)";
  EXPECT_EQ(fit->view.flags, msg::kViewSeenFrom);
  // The subject lies within the codec's box (both from the same seeded Gaussians).
  for (int a = 0; a < 3; ++a) {
    EXPECT_LE(fit->view.subject_min[a], fit->view.subject_max[a]);
    EXPECT_GE(fit->view.subject_min[a], fit->params.box.min[a]);
    EXPECT_LE(fit->view.subject_max[a], fit->params.box.max[a]);
  }
}

}  // namespace
}  // namespace gauss
