// gauss-view's default camera through the real program, headless (no window, no host):
// `gauss-view --scene FILE --headless` without --path renders a few frames from the camera
// the library computes (scene_framing.h + scene_up.h) and writes it as final_camera.json.
//   - a y-down scene (the 3DGS/COLMAP convention: a column whose top is at y = -2, red at
//     the top, blue at the bottom) opens upright: the camera's image-up is -y and the red
//     top is drawn above the blue bottom; --up +y turns it over, on purpose;
//   - the written camera is the library's framing of the scene's robust bounds;
//   - degenerate scenes (one Gaussian, every opacity zero) still give a finite camera and
//     exit 0; a file whose centres are not finite is refused by its reader, by name;
//   - --view side / top opens the library's preset framings of the same box;
//   - a bad --up or --view and --headless --host without --path are refused with exit 2 and
//     say why.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "child_process.h"
#include "gauss/engine/camera_io.h"
#include "gauss/engine/image_io.h"
#include "gauss/engine/ply_gaussian.h"
#include "gauss/engine/scene_framing.h"
#include "gauss/engine/scene_up.h"
#include "nan_ply.h"
#include "test_data.h"
#include "text_file.h"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using gauss::test::read_text;
using nlohmann::json;

constexpr std::uint32_t kW = 160, kH = 120;

struct ViewRun {
  int rc{-1};
  std::string log;
};

ViewRun run_view(const fs::path& out, const std::string& name, const std::vector<std::string>& args) {
  std::vector<std::string> argv{GAUSS_VIEW_EXE};
  argv.insert(argv.end(), args.begin(), args.end());
  gauss::test::ChildProcess p;
  const fs::path log = out / (name + ".log");
  if (!p.start(argv, log)) return {};
  auto rc = p.wait(180s);
  if (!rc) p.stop(SIGKILL);
  return {rc.value_or(-1), read_text(log)};
}

gauss::Gaussian blob(glm::vec3 p, glm::vec3 rgb) {
  gauss::Gaussian g;
  g.position = p;
  g.log_scale = glm::vec3(-3.0f);
  g.opacity_logit = 5.0f;
  g.sh_dc = (rgb - 0.5f) / 0.28209479f;
  return g;
}

// Three strands, 2 m tall, from y = 0 (blue, the floor) to y = -2 (red, the top): upright
// in the 3DGS convention, where y points down.
gauss::GaussianCloud y_down_column() {
  gauss::GaussianCloud c;
  for (int i = 0; i <= 40; ++i)
    for (int s = -1; s <= 1; ++s) {
      const float t = i / 40.0f;
      c.gaussians.push_back(blob({0.1f * s, -2.0f * t, 0.0f}, {t, 0.2f, 1.0f - t}));
    }
  return c;
}

glm::dvec3 image_up(const gauss::Camera& c) {
  return -glm::normalize(glm::dvec3(glm::inverse(c.world_to_camera)[1]));
}

// Mean row of the pixels that are clearly red (r > 2b) and clearly blue (b > 2r).
struct Rows {
  double red{0.0}, blue{0.0};
  std::size_t reds{0}, blues{0};
};
Rows colour_rows(const gauss::ImageRGBA8& img) {
  Rows r;
  for (std::uint32_t y = 0; y < img.height; ++y)
    for (std::uint32_t x = 0; x < img.width; ++x) {
      const std::uint8_t* p = &img.pixels[(std::size_t(y) * img.width + x) * 4];
      if (p[0] > 60 && p[0] > 2 * p[2]) r.red += y, ++r.reds;
      if (p[2] > 60 && p[2] > 2 * p[0]) r.blue += y, ++r.blues;
    }
  if (r.reds) r.red /= double(r.reds);
  if (r.blues) r.blue /= double(r.blues);
  return r;
}

TEST(ViewDefaultCamera, YDownSceneOpensUprightAsTheLibraryFramesIt) {
  const fs::path out = gauss::test::fresh_output_dir("e2e_view_default_camera_upright");
  const gauss::GaussianCloud cloud = y_down_column();
  ASSERT_TRUE(gauss::write_gaussian_ply(out / "column.ply", cloud).ok());
  const std::string size = std::to_string(kW) + "x" + std::to_string(kH);
  const ViewRun run = run_view(out, "view", {"--scene", (out / "column.ply").string(), "--headless", "--size", size,
                                         "--out", (out / "view").string()});
  ASSERT_EQ(run.rc, 0) << run.log;
  EXPECT_NE(run.log.find("its default camera (up -y"), std::string::npos) << run.log;
  auto cam = gauss::read_camera_json(out / "view" / "final_camera.json");
  ASSERT_TRUE(cam.ok()) << cam.message();
  EXPECT_GT(glm::dot(image_up(*cam), glm::dvec3(0, -1, 0)), 0.9) << "image-up is the scene's up, -y";

  // The very camera the library makes for these bounds and gauss-view's lens (70 degrees).
  gauss::FramingLens lens;
  lens.width = kW;
  lens.height = kH;
  lens.fx = lens.fy = 0.5 * kW / std::tan(70.0 * 3.14159265358979323846 / 360.0);
  const gauss::RobustBounds box = gauss::robust_bounds(cloud.gaussians);
  const gauss::Camera expect = gauss::framed_camera(gauss::frame_bounds(box.lo, box.hi, gauss::kColmapUp, lens), lens);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(cam->world_to_camera[i][j], expect.world_to_camera[i][j], 1e-9);
  EXPECT_NEAR(cam->fx, lens.fx, 1e-9);

  const json summary = json::parse(read_text(out / "view" / "summary.json"));
  EXPECT_EQ(summary["frames"].get<int>(), 3) << "a few frames";
  EXPECT_EQ(summary["default_camera"]["up"], json::array({0.0, -1.0, 0.0}));
  EXPECT_TRUE(summary["default_camera"]["opacity_weighted"].get<bool>());
  EXPECT_TRUE(fs::exists(out / "view" / "frames" / "frame_000002.png"));

  auto img = gauss::read_png_rgba8(out / "view" / "final.png");
  ASSERT_TRUE(img.ok()) << img.message();
  const Rows rows = colour_rows(*img);
  ASSERT_GT(rows.reds, 20u);
  ASSERT_GT(rows.blues, 20u);
  EXPECT_LT(rows.red, rows.blue) << "the top (red) is drawn above the bottom (blue)";

  // --up +y: the user says the scene is y up; it is shown so, upside down for this scene.
  const ViewRun flipped = run_view(out, "flipped", {"--scene", (out / "column.ply").string(), "--headless", "--size",
                                                size, "--up", "+y", "--out", (out / "flipped").string()});
  ASSERT_EQ(flipped.rc, 0) << flipped.log;
  auto fcam = gauss::read_camera_json(out / "flipped" / "final_camera.json");
  ASSERT_TRUE(fcam.ok()) << fcam.message();
  EXPECT_GT(glm::dot(image_up(*fcam), glm::dvec3(0, 1, 0)), 0.9);
  auto fimg = gauss::read_png_rgba8(out / "flipped" / "final.png");
  ASSERT_TRUE(fimg.ok()) << fimg.message();
  const Rows frows = colour_rows(*fimg);
  EXPECT_GT(frows.red, frows.blue);
}

// --view picks the preset the scene opens with: the library's side and top framings.
TEST(ViewDefaultCamera, ViewOptionOpensThePreset) {
  const fs::path out = gauss::test::fresh_output_dir("e2e_view_default_camera_preset");
  const gauss::GaussianCloud cloud = y_down_column();
  ASSERT_TRUE(gauss::write_gaussian_ply(out / "column.ply", cloud).ok());
  gauss::FramingLens lens;
  lens.width = kW;
  lens.height = kH;
  lens.fx = lens.fy = 0.5 * kW / std::tan(70.0 * 3.14159265358979323846 / 360.0);
  const gauss::RobustBounds box = gauss::robust_bounds(cloud.gaussians);
  const std::string size = std::to_string(kW) + "x" + std::to_string(kH);
  for (const auto& [name, preset] : {std::pair{"side", gauss::ViewPreset::Side}, std::pair{"top", gauss::ViewPreset::Top}}) {
    SCOPED_TRACE(name);
    const ViewRun run = run_view(out, name, {"--scene", (out / "column.ply").string(), "--headless", "--size", size,
                                             "--view", name, "--out", (out / name).string()});
    ASSERT_EQ(run.rc, 0) << run.log;
    auto cam = gauss::read_camera_json(out / name / "final_camera.json");
    ASSERT_TRUE(cam.ok()) << cam.message();
    const gauss::Camera expect =
        gauss::framed_camera(gauss::frame_preset(box.lo, box.hi, gauss::kColmapUp, lens, preset), lens);
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) EXPECT_NEAR(cam->world_to_camera[i][j], expect.world_to_camera[i][j], 1e-9);
  }
  const ViewRun bad = run_view(out, "bad", {"--scene", (out / "column.ply").string(), "--headless", "--view", "back"});
  EXPECT_EQ(bad.rc, 2) << bad.log;
}

TEST(ViewDefaultCamera, DegenerateScenesGetAFiniteCamera) {
  const fs::path out = gauss::test::fresh_output_dir("e2e_view_default_camera_degenerate");
  gauss::GaussianCloud one;
  one.gaussians.push_back(blob({3.0f, -2.0f, 7.0f}, {1.0f, 0.5f, 0.2f}));
  gauss::GaussianCloud transparent = y_down_column();
  for (auto& g : transparent.gaussians) g.opacity_logit = -1000.0f;  // sigmoid underflows to 0
  ASSERT_TRUE(gauss::write_gaussian_ply(out / "one.ply", one).ok());
  ASSERT_TRUE(gauss::write_gaussian_ply(out / "transparent.ply", transparent).ok());
  // No finite centre: every reader leaves a Gaussian with a non-finite position out, and a
  // file of nothing else is refused (the library's framing of such a set is tested in
  // engine_scene_framing), so the program says which file and where.
  {
    std::ofstream splat(out / "nan.splat", std::ios::binary);
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    for (const float pos : {nan, inf}) {
      const float xyz_scale[6] = {pos, pos, -pos, 0.05f, 0.05f, 0.05f};
      const unsigned char rgba_rot[8] = {200, 100, 50, 255, 255, 128, 128, 128};
      splat.write(reinterpret_cast<const char*>(xyz_scale), sizeof xyz_scale);
      splat.write(reinterpret_cast<const char*>(rgba_rot), sizeof rgba_rot);
    }
  }
  for (const char* file : {"one.ply", "transparent.ply"}) {
    SCOPED_TRACE(file);
    const std::string name = fs::path(file).stem().string();
    const ViewRun run = run_view(out, name, {"--scene", (out / file).string(), "--headless", "--size", "96x64",
                                             "--out", (out / name).string()});
    ASSERT_EQ(run.rc, 0) << run.log;
    auto cam = gauss::read_camera_json(out / name / "final_camera.json");
    ASSERT_TRUE(cam.ok()) << cam.message();  // the reader rejects any NaN or Inf
    EXPECT_GT(glm::dot(image_up(*cam), glm::dvec3(0, -1, 0)), 0.9);
  }
  const json summary = json::parse(read_text(out / "transparent" / "summary.json"));
  EXPECT_FALSE(summary["default_camera"]["opacity_weighted"].get<bool>()) << "zero opacity: centres counted alike";
  const ViewRun nan = run_view(out, "nan", {"--scene", (out / "nan.splat").string(), "--headless", "--size", "96x64",
                                           "--out", (out / "nan").string()});
  EXPECT_EQ(nan.rc, 1) << nan.log;
  EXPECT_NE(nan.log.find("nan.splat: every one of its 2 records is unusable (the first: splat 0: non-finite position"),
            std::string::npos)
      << nan.log;

  // One NaN among 123 Gaussians (a trainer that diverged once): the scene opens without it,
  // and the viewer says which one it left out.
  const std::string text = gauss::test::ascii_ply_with_nans(y_down_column(), [](std::size_t v) { return v == 5; });
  ASSERT_FALSE(text.empty());
  std::ofstream(out / "one_nan.ply") << text;
  const ViewRun one_nan = run_view(out, "one_nan", {"--scene", (out / "one_nan.ply").string(), "--headless", "--size",
                                                   "96x64", "--out", (out / "one_nan").string()});
  ASSERT_EQ(one_nan.rc, 0) << one_nan.log;
  EXPECT_NE(one_nan.log.find("one_nan.ply: left out 1 of 123 Gaussians with a non-finite value (the first: vertex 5, "
                             "property 'x' (line "),
            std::string::npos)
      << one_nan.log;
  EXPECT_NE(one_nan.log.find("(122 Gaussians, SH 0), 1 non-finite Gaussians skipped"), std::string::npos) << one_nan.log;
}

TEST(ViewDefaultCamera, BadCommandLinesSayWhy) {
  const fs::path out = gauss::test::fresh_output_dir("e2e_view_default_camera_cli");
  gauss::GaussianCloud one;
  one.gaussians.push_back(blob({0.0f, 0.0f, 0.0f}, {1.0f, 1.0f, 1.0f}));
  ASSERT_TRUE(gauss::write_gaussian_ply(out / "one.ply", one).ok());
  const ViewRun bad_up = run_view(out, "bad_up", {"--scene", (out / "one.ply").string(), "--headless", "--up", "sideways"});
  EXPECT_EQ(bad_up.rc, 2) << bad_up.log;
  EXPECT_NE(bad_up.log.find("+x -x +y -y +z -z"), std::string::npos) << bad_up.log;
  // A host without --path is framed from the scene box it sends: none comes from a port
  // nobody serves, which is said within --settle-timeout.
  const ViewRun host = run_view(out, "host", {"--host", "127.0.0.1:9", "--headless", "--settle-timeout", "1"});
  EXPECT_EQ(host.rc, 1) << host.log;
  EXPECT_NE(host.log.find("no scene from host 127.0.0.1:9 within 1 s"), std::string::npos) << host.log;
}

}  // namespace
