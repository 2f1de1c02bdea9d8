// gauss-eval on an RGB-D capture: a 3DMatch-layout folder written here from room 1's exact
// colour and depth at three of its trajectory cameras. The capture is served as gauss-host
// serves one (Gaussians seeded from the frames, the surface fused, a frame an epoch) and
// judged against its own frames: GT figures present at its cameras, aligned (a camera off
// by a pixel's worth of pose would fall far below the bound), HS equal to the host's render
// of the sent set, every frame after the first replayed as a model edit.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "child_process.h"
#include "text_file.h"
#include "gauss/engine/camera.h"
#include "gauss/engine/image_io.h"
#include "gauss/engine/synthetic_scene.h"
#include "gauss/engine/tsdf.h"

namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

using gauss::test::read_text;

constexpr std::uint32_t kFrameW = 192, kFrameH = 144;

// Room 1's exact frames at three trajectory cameras, as a Kinect capture folder would hold
// them (depth in millimetres, 0 = no return).
void write_room_capture(const fs::path& dir) {
  gauss::SyntheticSceneConfig sc;
  sc.variant = 1;
  sc.target_gaussians = 8000;
  sc.epochs = 4;
  auto scene = gauss::SyntheticScene::create(sc);
  ASSERT_TRUE(scene.ok()) << scene.message();
  gauss::SceneStore store;
  while (!scene->finished()) ASSERT_TRUE(scene->produce(store).ok());
  fs::create_directories(dir);
  const std::vector<gauss::Camera>& path = scene->trajectory();
  for (int k = 0; k < 3; ++k) {
    const gauss::Camera cam = gauss::resized_camera(path[std::size_t(k) * path.size() / 6], kFrameW, kFrameH);
    if (k == 0)
      std::ofstream(dir / "camera-intrinsics.txt")
          << cam.fx << " 0 " << cam.cx << "\n0 " << cam.fy << " " << cam.cy << "\n0 0 1\n";
    const gauss::RgbdFrame f = gauss::synthetic_rgbd_frame(*scene, cam, gauss::Epoch(1));
    const std::string stem = "frame-00000" + std::to_string(k);
    gauss::ImageU16 depth;
    depth.width = f.width;
    depth.height = f.height;
    for (float d : f.depth) depth.pixels.push_back(std::uint16_t(d > 0.0f ? std::lround(d * 1000.0f) : 0));
    ASSERT_TRUE(gauss::write_png_u16(dir / (stem + ".depth.png"), depth).ok());
    ASSERT_TRUE(gauss::write_png(dir / (stem + ".color.png"), f.colour).ok());
    std::ofstream pose(dir / (stem + ".pose.txt"));
    pose.precision(17);
    for (int r = 0; r < 4; ++r)
      pose << f.camera_to_world[0][r] << ' ' << f.camera_to_world[1][r] << ' ' << f.camera_to_world[2][r] << ' '
           << f.camera_to_world[3][r] << '\n';
  }
}

int run_eval(const fs::path& log, const std::vector<std::string>& args) {
  gauss::test::ChildProcess eval;
  EXPECT_TRUE(eval.start(args, log));
  const auto rc = eval.wait(240s);
  if (!rc) eval.stop(SIGKILL);
  return rc.value_or(-1);
}

TEST(GaussEvalCapture, ACaptureIsJudgedAgainstItsOwnFrames) {
  const fs::path base = fs::path(GAUSS_TEST_OUTPUT_DIR) / "eval_app_gauss_eval_capture";
  fs::remove_all(base);
  ASSERT_NO_FATAL_FAILURE(write_room_capture(base / "room1_capture"));
  const fs::path out = base / "report";
  fs::create_directories(out);
  ASSERT_EQ(run_eval(out / "eval.log", {GAUSS_EVAL_EXE, "--scene", (base / "room1_capture").string(), "--rgbd-stride",
                                        "2", "--surface", "fused", "--budget", "6000", "--size", "96x72", "--cameras",
                                        "3", "--quiet", "0.25", "--no-semantic", "--no-temporal", "--epoch-period",
                                        "0.2", "--no-timing", "--name", "ctest-capture", "--out", out.string()}),
            0)
      << read_text(out / "eval.log");
  const nlohmann::json r = nlohmann::json::parse(read_text(out / "report.json"));
  ASSERT_EQ(r["scenes"].size(), 1u);
  const nlohmann::json& scene = r["scenes"][0];
  EXPECT_EQ(scene["name"], "room1_capture");
  EXPECT_TRUE(scene["ground_truth"].get<bool>());
  EXPECT_EQ(scene["snapshots"].get<int>(), 3) << "one epoch per frame";
  EXPECT_EQ(scene["capture_frames"].size(), 3u);
  EXPECT_GT(scene["surface_chunks"].get<std::uint64_t>(), 0u) << "--surface fused";
  ASSERT_EQ(scene["fidelity"]["cameras"].size(), 3u);
  for (const nlohmann::json& c : scene["fidelity"]["cameras"]) {
    ASSERT_TRUE(c["gt_pc"].is_object()) << "a capture's camera has its frame as ground truth: " << c.dump();
    ASSERT_TRUE(c["gt_hs"].is_object()) << c.dump();
    // The seeded discs redraw the exact frames they came from: well above what a view
    // misaligned by a few pixels scores against the room's textures.
    EXPECT_GT(c["gt_pc"]["psnr_db"].get<double>(), 20.0) << c.dump();
    EXPECT_GT(c["coverage"]["gt_valid"].get<double>(), 0.95) << "the closed room has depth everywhere";
    EXPECT_EQ(c["hs_vs_sent"]["differing_pixels"].get<std::uint64_t>(), 0u);
  }
  ASSERT_TRUE(scene.contains("model_latency")) << "the frames after the first are replayed as model edits";
  EXPECT_EQ(scene["model_latency"]["epochs"].size(), 2u) << scene["model_latency"].dump();
  EXPECT_TRUE(r["checks"]["hs_equals_sent_render"].get<bool>());
  EXPECT_TRUE(r["checks"]["all_converged"].get<bool>());
  EXPECT_TRUE(r["definitions"].contains("capture ground truth"));
  EXPECT_EQ(r["validation_errors"].get<std::uint64_t>(), 0u);
}

TEST(GaussEvalCapture, ASizeThatDoesNotDivideTheFramesIsRefusedWithTheSizes) {
  const fs::path base = fs::path(GAUSS_TEST_OUTPUT_DIR) / "eval_app_gauss_eval_capture_size";
  fs::remove_all(base);
  ASSERT_NO_FATAL_FAILURE(write_room_capture(base / "capture"));
  const fs::path log = base / "eval.log";
  EXPECT_NE(run_eval(log, {GAUSS_EVAL_EXE, "--scene", (base / "capture").string(), "--size", "100x72", "--no-timing",
                           "--out", (base / "report").string()}),
            0);
  const std::string text = read_text(log);
  EXPECT_NE(text.find("192x144"), std::string::npos) << text;
  EXPECT_NE(text.find("whole factor"), std::string::npos) << text;
  // And a surface kind the scene cannot have is a usage error before any work.
  EXPECT_EQ(run_eval(base / "surface.log", {GAUSS_EVAL_EXE, "--scene", (base / "capture").string(), "--surface",
                                           "analytic", "--out", (base / "report").string()}),
            2)
      << read_text(base / "surface.log");
}

}  // namespace
