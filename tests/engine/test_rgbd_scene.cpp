// An RGB-D capture as a scene: Gaussians seeded from frames (placement, orientation, size,
// colour, no second layer where the scene already shows the surface, bad pixels and bad
// frames), and the capture as a SceneSource (one epoch per frame, a bad frame skipped with a
// line, the surface fused beside).
#include <cmath>
#include <fstream>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>

#include "gauss/engine/camera.h"
#include "gauss/engine/codec.h"
#include "gauss/engine/image_io.h"
#include "gauss/engine/rgbd_scene.h"
#include "gauss/engine/rgbd_source.h"
#include "test_data.h"

namespace gauss {
namespace {
namespace fs = std::filesystem;

constexpr std::uint32_t kW = 64, kH = 48;
constexpr double kFocal = 50.0;

// A camera at `eye` looking along +z at a wall at z = wall_z, every pixel its depth, colour
// (200, 40, 10).
RgbdFrame wall_frame(double wall_z, glm::dvec3 eye = glm::dvec3(0.0)) {
  RgbdFrame f;
  f.name = "wall";
  f.width = kW;
  f.height = kH;
  f.fx = f.fy = kFocal;
  f.cx = kW / 2.0;
  f.cy = kH / 2.0;
  f.camera_to_world = opencv_look_at(eye, eye + glm::dvec3(0, 0, 1), glm::dvec3(0, -1, 0));
  f.depth.assign(std::size_t(kW) * kH, float(wall_z - eye.z));
  f.colour.width = kW;
  f.colour.height = kH;
  f.colour.pixels.resize(std::size_t(kW) * kH * 4);
  for (std::size_t k = 0; k < std::size_t(kW) * kH; ++k) {
    f.colour.pixels[4 * k + 0] = 200;
    f.colour.pixels[4 * k + 1] = 40;
    f.colour.pixels[4 * k + 2] = 10;
    f.colour.pixels[4 * k + 3] = 255;
  }
  return f;
}

glm::vec3 normal_of(const Gaussian& g) {
  const glm::quat q(g.rotation[0], g.rotation[1], g.rotation[2], g.rotation[3]);
  return glm::mat3_cast(q)[2];
}

TEST(RgbdSeeder, SeedsOneFlatDiscPerBlockOnTheWallFacingTheCamera) {
  RgbdSeedConfig c;
  c.stride = 4;
  RgbdSeeder seeder(c);
  auto g = seeder.seed(wall_frame(1.0));
  ASSERT_TRUE(g) << g.message();
  ASSERT_EQ(g->size(), std::size_t(kW / 4) * (kH / 4));
  EXPECT_EQ(seeder.seeded(), g->size());
  const double spacing = 1.0 * 4 / kFocal;
  for (const Gaussian& s : *g) {
    EXPECT_NEAR(s.position.z, 1.0f, 1e-5f);
    const glm::vec3 n = normal_of(s);
    EXPECT_NEAR(n.z, -1.0f, 1e-5f) << "the disc faces the camera at the origin";
    EXPECT_NEAR(std::exp(s.log_scale.x), 0.65 * spacing, 1e-6);
    EXPECT_NEAR(std::exp(s.log_scale.y), 0.65 * spacing, 1e-6);
    EXPECT_NEAR(std::exp(s.log_scale.z), 0.065 * spacing, 1e-6);
    const glm::vec3 colour = 0.5f + 0.28209479177387814f * s.sh_dc;
    EXPECT_NEAR(colour.r, 200 / 255.0f, 1e-5f);
    EXPECT_NEAR(colour.g, 40 / 255.0f, 1e-5f);
    EXPECT_NEAR(colour.b, 10 / 255.0f, 1e-5f);
    EXPECT_NEAR(1.0f / (1.0f + std::exp(-s.opacity_logit)), c.opacity, 1e-5f);
    EXPECT_EQ(s.id, GaussianId{0}) << "ids are the caller's";
  }
  // The block centres, back-projected: x = (px + 0.5 - cx) / f at depth 1.
  EXPECT_NEAR((*g)[0].position.x, (2 + 0.5 - kW / 2.0) / kFocal, 1e-5);
}

TEST(RgbdSeeder, ASurfaceTheSceneAlreadyShowsSeedsNothingAgain) {
  RgbdSeeder seeder(RgbdSeedConfig{});
  auto first = seeder.seed(wall_frame(2.0));
  ASSERT_TRUE(first) << first.message();
  ASSERT_EQ(first->size(), std::size_t(kW / 4) * (kH / 4));
  auto again = seeder.seed(wall_frame(2.0));
  ASSERT_TRUE(again) << again.message();
  EXPECT_TRUE(again->empty()) << "the same view adds no second layer";
  // The camera 3 cm further back, the wall measured 2 cm nearer than it is (depth noise):
  // the same surface, no layer at its noise (the view is less than a block wider).
  RgbdFrame noisy = wall_frame(2.0, glm::dvec3(0.0, 0.0, -0.03));
  for (float& d : noisy.depth) d -= 0.02f;
  auto shifted = seeder.seed(noisy);
  ASSERT_TRUE(shifted) << shifted.message();
  EXPECT_TRUE(shifted->empty()) << shifted->size() << " Gaussians seeded on a surface already seeded";
  // Something 0.5 m in front of the wall in the left half: only that half seeds, all of it.
  RgbdFrame box = wall_frame(2.0);
  for (std::uint32_t y = 0; y < kH; ++y)
    for (std::uint32_t x = 0; x < kW / 2; ++x) box.depth[std::size_t(y) * kW + x] = 1.5f;
  auto front = seeder.seed(box);
  ASSERT_TRUE(front) << front.message();
  EXPECT_EQ(front->size(), std::size_t(kW / 8) * (kH / 4));
  for (const Gaussian& g : *front) EXPECT_NEAR(g.position.z, 1.5f, 1e-5f);
}

TEST(RgbdSeeder, ALaterFrameSeedsWhatTheEarlierOnesDidNotSee) {
  RgbdSeeder seeder(RgbdSeedConfig{});
  ASSERT_TRUE(seeder.seed(wall_frame(2.0)));
  // Turned 90 degrees to the right (+x): a wall at x = 2 that the first view never saw.
  RgbdFrame side = wall_frame(2.0);
  side.camera_to_world = opencv_look_at(glm::dvec3(0.0), glm::dvec3(1, 0, 0), glm::dvec3(0, -1, 0));
  auto g = seeder.seed(side);
  ASSERT_TRUE(g) << g.message();
  EXPECT_EQ(g->size(), std::size_t(kW / 4) * (kH / 4));
  for (const Gaussian& s : *g) {
    EXPECT_NEAR(s.position.x, 2.0f, 1e-5f);
    EXPECT_NEAR(normal_of(s).x, -1.0f, 1e-5f);
  }
}

TEST(RgbdSeeder, MissingNonFiniteAndOutOfRangeDepthsAndFlyingPointsSeedNothing) {
  RgbdSeedConfig c;
  c.stride = 4;
  RgbdFrame f = wall_frame(1.0);
  const auto at = [&](std::uint32_t bx, std::uint32_t by) -> float& {
    return f.depth[std::size_t(by * 4 + 2) * kW + bx * 4 + 2];
  };
  at(1, 1) = 0.0f;
  at(3, 1) = std::nanf("");
  at(5, 1) = std::numeric_limits<float>::infinity();
  at(7, 1) = -1.0f;
  at(9, 1) = 50.0f;  // beyond max_depth
  at(5, 6) = 1.5f;   // a flying point: 50 % behind all its neighbours
  RgbdSeeder seeder(c);
  auto g = seeder.seed(f);
  ASSERT_TRUE(g) << g.message();
  EXPECT_EQ(g->size(), std::size_t(kW / 4) * (kH / 4) - 6);
  for (const Gaussian& s : *g) {
    EXPECT_TRUE(std::isfinite(s.position.x) && std::isfinite(s.log_scale.x) && std::isfinite(s.rotation[0]));
    EXPECT_NEAR(s.position.z, 1.0f, 1e-5f);
  }
}

TEST(RgbdSeeder, AStepEdgeKeepsBothSurfacesWithTheirOwnNormals) {
  RgbdSeedConfig c;
  c.stride = 4;
  RgbdFrame f = wall_frame(1.0);
  for (std::uint32_t y = 0; y < kH; ++y)
    for (std::uint32_t x = kW / 2; x < kW; ++x) f.depth[std::size_t(y) * kW + x] = 2.0f;
  RgbdSeeder seeder(c);
  auto g = seeder.seed(f);
  ASSERT_TRUE(g) << g.message();
  EXPECT_EQ(g->size(), std::size_t(kW / 4) * (kH / 4)) << "edge blocks use their neighbour on the same side";
  for (const Gaussian& s : *g) EXPECT_NEAR(normal_of(s).z, -1.0f, 1e-5f);
}

TEST(RgbdSeeder, BadFramesAreRefusedAndMarkNoCell) {
  RgbdSeeder seeder(RgbdSeedConfig{});
  RgbdFrame short_depth = wall_frame(1.0);
  short_depth.depth.pop_back();
  RgbdFrame no_focal = wall_frame(1.0);
  no_focal.fx = 0.0;
  RgbdFrame nan_pose = wall_frame(1.0);
  nan_pose.camera_to_world[3][0] = std::nan("");
  RgbdFrame small_colour = wall_frame(1.0);
  small_colour.colour.width = 8;
  for (const RgbdFrame* f : {&short_depth, &no_focal, &nan_pose, &small_colour}) {
    auto g = seeder.seed(*f);
    EXPECT_FALSE(g);
    EXPECT_NE(g.message().find("'wall'"), std::string::npos) << g.message();
  }
  EXPECT_EQ(seeder.seeded(), 0u);
  RgbdSeedConfig bad;
  bad.depth_tolerance = 0.0f;
  EXPECT_FALSE(RgbdSeeder(bad).seed(wall_frame(1.0)));
  bad = RgbdSeedConfig{};
  bad.opacity = 1.0f;
  EXPECT_FALSE(validate(bad));
}

TEST(RgbdSeeder, AFrameWithoutColourSeedsGrey) {
  RgbdFrame f = wall_frame(1.0);
  f.colour = ImageRGBA8{};
  RgbdSeeder seeder(RgbdSeedConfig{});
  auto g = seeder.seed(f);
  ASSERT_TRUE(g && !g->empty());
  EXPECT_EQ((*g)[0].sh_dc, glm::vec3(0.0f));
}

// A 3DMatch-layout folder of wall frames (the camera stepping back 0.3 m and right 0.1 m a
// frame: each sees more of the wall), the middle one's depth PNG corrupt.
fs::path write_capture(const std::string& name) {
  const fs::path dir = test::output_dir() / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "camera-intrinsics.txt") << kFocal << " 0 " << kW / 2.0 << "\n0 " << kFocal << " " << kH / 2.0
                                               << "\n0 0 1\n";
  for (int i = 0; i < 3; ++i) {
    const RgbdFrame f = wall_frame(1.5, glm::dvec3(0.1 * i, 0.0, -0.3 * i));
    const std::string stem = "frame-00000" + std::to_string(i);
    ImageU16 depth;
    depth.width = kW;
    depth.height = kH;
    for (float d : f.depth) depth.pixels.push_back(std::uint16_t(std::lround(d * 1000.0)));
    EXPECT_TRUE(write_png_u16(dir / (stem + ".depth.png"), depth));
    EXPECT_TRUE(write_png(dir / (stem + ".color.png"), f.colour));
    std::ofstream pose(dir / (stem + ".pose.txt"));
    for (int r = 0; r < 4; ++r) pose << f.camera_to_world[0][r] << ' ' << f.camera_to_world[1][r] << ' '
                                     << f.camera_to_world[2][r] << ' ' << f.camera_to_world[3][r] << '\n';
  }
  std::ofstream(dir / "frame-000001.depth.png", std::ios::trunc) << "not a png";
  return dir;
}

TEST(RgbdCaptureSource, EachFrameIsAnEpochAndABadFrameIsSkippedWithALine) {
  const fs::path dir = write_capture("rgbd_scene_capture");
  EXPECT_TRUE(is_rgbd_capture(dir));
  EXPECT_FALSE(is_rgbd_capture(dir / "frame-000000.color.png"));
  EXPECT_FALSE(is_rgbd_capture(test::output_dir()));
  std::vector<std::string> lines;
  RgbdSceneOptions o;
  o.surface->voxel_size = 0.05f;
  auto src = open_rgbd_capture(dir, o, [&](const std::string& l) { lines.push_back(l); });
  ASSERT_TRUE(src) << src.message();
  SceneStore store;
  auto e1 = (*src)->next_epoch(store);
  ASSERT_TRUE(e1 && *e1) << (e1 ? "" : e1.message());
  const std::size_t after_first = store.size();
  EXPECT_EQ(after_first, std::size_t(kW / 4) * (kH / 4));
  EXPECT_FALSE(store.surface_chunks().empty()) << "the surface is fused beside the Gaussians";
  auto e2 = (*src)->next_epoch(store);  // frame 1 is corrupt: frame 2 gives this epoch
  ASSERT_TRUE(e2 && *e2) << (e2 ? "" : e2.message());
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_NE(lines[0].find("frame-000001"), std::string::npos) << lines[0];
  EXPECT_NE(lines[0].find("skipped"), std::string::npos) << lines[0];
  EXPECT_GT(store.size(), after_first) << "frame 2 sees more of the wall: new Gaussians at its rim";
  EXPECT_EQ(store.epoch(), Epoch(2));
  auto end = (*src)->next_epoch(store);
  ASSERT_TRUE(end);
  EXPECT_FALSE(*end);
  EXPECT_EQ(store.epoch(), Epoch(2));
}

TEST(RgbdCaptureSource, ItsCodecCoversEveryFrameNotJustTheFirst) {
  const fs::path dir = write_capture("rgbd_scene_codec");
  RgbdSceneOptions o;
  auto fit = fit_capture(dir, o);
  ASSERT_TRUE(fit) << fit.message();
  const CodecParams* params = &fit->params;
  auto src = open_rgbd_capture(dir, o, [](const std::string&) {});
  ASSERT_TRUE(src);
  SceneStore store;
  ASSERT_TRUE((*src)->next_epoch(store));
  const CodecParams first_only = fit_codec_params(store.gaussians(), store.sh_degree());
  while (true) {
    auto r = (*src)->next_epoch(store);
    ASSERT_TRUE(r);
    if (!*r) break;
  }
  std::size_t outside_first = 0;
  for (const Gaussian& g : store.gaussians()) {
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(g.position[a], params->box.min[a]);
      EXPECT_LE(g.position[a], params->box.max[a]);
    }
    EXPECT_GE(g.log_scale.z, params->log_scale_min);
    EXPECT_LE(g.log_scale.x, params->log_scale_max);
    outside_first += g.position.x > first_only.box.max.x || g.position.x < first_only.box.min.x;
  }
  EXPECT_GT(outside_first, 0u) << "the later frame sees further right than the first: the test needs that";
}

TEST(RgbdCaptureSource, ACaptureWithNoUsableFrameIsAnError) {
  const fs::path dir = write_capture("rgbd_scene_unusable");
  fs::remove(dir / "frame-000000.depth.png");
  fs::remove(dir / "frame-000002.pose.txt");
  auto src = open_rgbd_capture(dir, RgbdSceneOptions{}, [](const std::string&) {});
  ASSERT_TRUE(src) << src.message();  // frame 0 has no depth: not listed; 1 corrupt; 2 no pose
  SceneStore store;
  auto r = (*src)->next_epoch(store);
  ASSERT_FALSE(r);
  EXPECT_NE(r.message().find("none of its"), std::string::npos) << r.message();
  EXPECT_EQ(store.size(), 0u);
  EXPECT_FALSE(store.in_epoch());
}

TEST(RgbdCaptureSource, TheStudyRoomSeedsARoomScaleScene) {
  const auto dir = test::data_file("rgbd/sun3d_studyroom");
  if (!dir) GTEST_SKIP() << "../shared/data/rgbd/sun3d_studyroom absent (set GAUSS_DATA_DIR)";
  RgbdSceneOptions o;
  o.seed.stride = 8;
  o.surface.reset();
  auto src = open_rgbd_capture(*dir, o, [](const std::string& l) { ADD_FAILURE() << l; });
  ASSERT_TRUE(src) << src.message();
  SceneStore store;
  int epochs = 0;
  for (;;) {
    auto r = (*src)->next_epoch(store);
    ASSERT_TRUE(r) << r.message();
    if (!*r) break;
    ++epochs;
  }
  EXPECT_EQ(epochs, 5);
  // 80 x 60 blocks a frame; the first frame alone seeds most of its valid blocks.
  EXPECT_GT(store.size(), 4000u);
  EXPECT_LT(store.size(), 5u * 80 * 60);
  for (const Gaussian& g : store.gaussians()) ASSERT_TRUE(std::isfinite(g.position.x) && std::isfinite(g.log_scale.x));
}

}  // namespace
}  // namespace gauss
