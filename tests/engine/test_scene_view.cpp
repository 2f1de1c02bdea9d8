// The view a host announces for its scene (scene_view.h): a capture's up and robust subject
// box, the synthetic room's inside view, degenerate input kept finite, and the framing a
// client makes of it equal to a local viewer's of the same Gaussians. The RGB-D capture's view
// from its cameras uses the shared SUN3D frames (../shared/data/rgbd, skipped when absent).
#include <cmath>
#include <filesystem>
#include <limits>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "gauss/engine/rgbd_scene.h"
#include "gauss/engine/rgbd_source.h"
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

TEST(SceneView, AnRgbdCapturesUpIsItsCamerasUp) {
  const auto dir = test::data_file("rgbd/sun3d_studyroom");
  if (!dir) GTEST_SKIP() << "../shared/data/rgbd/sun3d_studyroom absent (set GAUSS_DATA_DIR)";
  const std::filesystem::path folder = *dir;
  RgbdSceneOptions o;
  o.seed.stride = 16;
  o.surface.reset();
  auto fit = fit_capture(folder, o);
  ASSERT_TRUE(fit.ok()) << fit.message();
  // The cameras' mean image-up, from their poses.
  auto frames = RgbdFolderSource::open(folder);
  ASSERT_TRUE(frames.ok()) << frames.message();
  glm::dvec3 sum(0.0);
  for (std::size_t i = 0; i < frames->frame_count(); ++i) {
    auto p = frames->frame_pose(i);
    ASSERT_TRUE(p.ok()) << p.message();
    sum -= glm::dvec3((*p)[1]);
  }
  EXPECT_LT(glm::length(glm::dvec3(fit->view.up) - glm::normalize(sum)), 1e-6);
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
