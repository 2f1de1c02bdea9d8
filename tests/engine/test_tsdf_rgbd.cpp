// Real RGB-D data: the SUN3D study room (five Kinect frames) fused into a mesh, and
// the folder readers (3DMatch/SUN3D and TUM layouts) on it.
#include <algorithm>
#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "gauss/engine/mesh_raster.h"
#include "gauss/engine/rgbd_source.h"
#include "gauss/engine/tsdf.h"
#include "test_data.h"

namespace gauss {
namespace {
namespace fs = std::filesystem;

constexpr const char* kStudyRoom = "rgbd/sun3d_studyroom";

TEST(RgbdSource, ReadsTheSun3dLayout) {
  GAUSS_REQUIRE_DATA(folder, kStudyRoom);
  auto src = RgbdFolderSource::open(folder);
  ASSERT_TRUE(src) << src.message();
  EXPECT_EQ(src->layout(), RgbdLayout::ThreeDMatch);
  ASSERT_EQ(src->frame_count(), 5u);
  auto f = src->load(0, Epoch(3));
  ASSERT_TRUE(f) << f.message();
  EXPECT_EQ(f->width, 640u);
  EXPECT_EQ(f->height, 480u);
  EXPECT_NEAR(f->fx, 570.34, 0.01);
  EXPECT_EQ(f->epoch, Epoch(3));
  EXPECT_EQ(f->colour.width, 640u);
  const auto valid = std::count_if(f->depth.begin(), f->depth.end(), [](float d) { return d > 0; });
  EXPECT_GT(valid, 100000);
  const float max_depth = *std::max_element(f->depth.begin(), f->depth.end());
  EXPECT_GT(max_depth, 0.5f);
  EXPECT_LT(max_depth, 10.0f) << "depth PNG is millimetres: must be scaled to metres";
}

TEST(TsdfRgbd, StudyRoomMeshReproducesTheInputDepthWithinOneVoxel) {
  GAUSS_REQUIRE_DATA(folder, kStudyRoom);
  auto src = RgbdFolderSource::open(folder);
  ASSERT_TRUE(src) << src.message();
  TsdfConfig cfg;
  // 2 cm voxels, default truncation (3 voxels). At 1 cm the medians are 1.0-1.5 cm:
  // the five frames disagree with each other by about a centimetre (sensor noise at
  // 2-3 m and pose error), while fusing a single frame meets 1 cm against itself.
  cfg.voxel_size = 0.02f;
  auto vol = TsdfVolume::create(cfg);
  ASSERT_TRUE(vol);
  std::vector<RgbdFrame> frames;
  for (std::size_t i = 0; i < src->frame_count(); ++i) {
    auto f = src->load(i, Epoch(i + 1));
    ASSERT_TRUE(f) << f.message();
    ASSERT_TRUE(vol->integrate(*f)) << src->frame_name(i);
    frames.push_back(std::move(*f));
  }
  const TriangleMesh mesh = vol->extract_all();
  ASSERT_GT(mesh.indices.size(), 10000u);
  for (const auto& f : frames) {
    const Camera cam = frame_camera(f);
    const std::vector<float> rendered = render_mesh_depth(mesh, cam);
    std::vector<float> diffs;
    for (std::size_t k = 0; k < rendered.size(); ++k)
      if (f.depth[k] > 0 && rendered[k] > 0) diffs.push_back(std::abs(rendered[k] - f.depth[k]));
    ASSERT_GT(diffs.size(), rendered.size() / 2) << f.name << ": the mesh must cover most valid pixels";
    std::nth_element(diffs.begin(), diffs.begin() + long(diffs.size() / 2), diffs.end());
    const float median = diffs[diffs.size() / 2];
    EXPECT_LE(median, cfg.voxel_size) << f.name << ": median |mesh depth - input depth| = " << median << " m";
  }
}

TEST(RgbdSource, ReadsTheTumLayoutAndPairsByTimestamp) {
  GAUSS_REQUIRE_DATA(folder, kStudyRoom);
  const fs::path tum = test::output_dir() / "tum_layout";
  fs::remove_all(tum);
  fs::create_directories(tum / "depth");
  fs::create_directories(tum / "rgb");
  const fs::path seq = folder / "seq-01";
  fs::copy_file(seq / "frame-000000.depth.png", tum / "depth" / "1.000000.png");
  fs::copy_file(seq / "frame-000000.color.png", tum / "rgb" / "1.010000.png");
  fs::copy_file(seq / "frame-000001.depth.png", tum / "depth" / "2.000000.png");  // no colour within 20 ms
  std::ofstream(tum / "depth.txt") << "# depth maps\n1.000000 depth/1.000000.png\n2.000000 depth/2.000000.png\n";
  std::ofstream(tum / "rgb.txt") << "# colour images\n1.010000 rgb/1.010000.png\n2.100000 rgb/1.010000.png\n";
  // 90 degrees about y: qy = sin(45), qw = cos(45).
  std::ofstream(tum / "groundtruth.txt") << "# timestamp tx ty tz qx qy qz qw\n"
                                            "0.995 1.0 2.0 3.0 0 0.7071067811865476 0 0.7071067811865476\n"
                                            "2.000 0 0 0 0 0 0 1\n";
  auto src = RgbdFolderSource::open(tum);
  ASSERT_TRUE(src) << src.message();
  EXPECT_EQ(src->layout(), RgbdLayout::Tum);
  ASSERT_EQ(src->frame_count(), 1u) << "the frame without colour within 20 ms is not listed";
  auto f = src->load(0, Epoch(1));
  ASSERT_TRUE(f) << f.message();
  EXPECT_DOUBLE_EQ(f->fx, 525.0);
  EXPECT_NEAR(f->camera_to_world[3][0], 1.0, 1e-12);
  EXPECT_NEAR(f->camera_to_world[2][0], 1.0, 1e-9) << "camera z maps to world x";
  // TUM depth is 5000 units per metre: the same PNG reads 5x smaller than as SUN3D.
  auto sun = RgbdFolderSource::open(folder);
  ASSERT_TRUE(sun);
  auto g = sun->load(0, Epoch(1));
  ASSERT_TRUE(g);
  for (std::size_t k = 0; k < g->depth.size(); k += 997) EXPECT_NEAR(f->depth[k] * 5.0f, g->depth[k], 1e-6f);
}

TEST(RgbdSource, MissingAndCorruptFilesNameTheFrame) {
  const fs::path dir = test::output_dir() / "bad_3dmatch";
  fs::remove_all(dir);
  fs::create_directories(dir);
  EXPECT_FALSE(RgbdFolderSource::open(dir / "absent"));
  auto none = RgbdFolderSource::open(dir);
  ASSERT_FALSE(none);
  EXPECT_NE(none.message().find("camera-intrinsics.txt"), std::string::npos) << none.message();
  std::ofstream(dir / "camera-intrinsics.txt") << "500 0 320\n0 500 240\n0 0 1\n";
  std::ofstream(dir / "frame-000000.depth.png") << "not a png";
  std::ofstream(dir / "frame-000000.pose.txt") << "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";
  auto src = RgbdFolderSource::open(dir);
  ASSERT_TRUE(src) << src.message();
  auto f = src->load(0, Epoch(1));
  ASSERT_FALSE(f);
  EXPECT_NE(f.message().find("frame-000000"), std::string::npos) << f.message();
  std::ofstream(dir / "bad-intrinsics.txt") << "500 0 320\n0 nan 240\n0 0 1\n";
  double fx, fy, cx, cy;
  auto st = read_intrinsics(dir / "bad-intrinsics.txt", fx, fy, cx, cy);
  ASSERT_FALSE(st);
  EXPECT_NE(st.message().find("value 5"), std::string::npos) << st.message();
  std::ofstream(dir / "short-pose.txt") << "1 0 0 0\n0 1 0 0\n";
  auto pose = read_pose_4x4(dir / "short-pose.txt");
  ASSERT_FALSE(pose);
  EXPECT_NE(pose.message().find("expected 16 numbers, found 8"), std::string::npos) << pose.message();
}

}  // namespace
}  // namespace gauss
