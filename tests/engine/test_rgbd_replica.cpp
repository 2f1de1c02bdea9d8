// The Replica RGB-D layout (results/frameNNNNNN.jpg + depthNNNNNN.png, traj.txt,
// cam_params.json) on a small hand-made capture of a known plane: the reader, the fused
// surface against the plane, and every bad input naming its frame or file.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "gauss/engine/image_io.h"
#include "gauss/engine/rgbd_source.h"
#include "gauss/engine/tsdf.h"
#include "replica_fixture.h"
#include "test_data.h"

namespace gauss {
namespace {
namespace fs = std::filesystem;

#define EXPECT_HAS(text, part) EXPECT_NE((text).find(part), std::string::npos) << (text)

TEST(RgbdReplica, ReadsTheLayout) {
  const auto plane = test::write_replica_plane(test::output_dir() / "replica_read");
  auto src = RgbdFolderSource::open(plane.folder);
  ASSERT_TRUE(src) << src.message();
  EXPECT_EQ(src->layout(), RgbdLayout::Replica);
  EXPECT_STREQ(rgbd_layout_name(src->layout()), "Replica");
  ASSERT_EQ(src->frame_count(), 3u);
  EXPECT_HAS(src->frame_name(2), "frame000002");
  auto f = src->load(1, Epoch(7));
  ASSERT_TRUE(f) << f.message();
  EXPECT_EQ(f->width, 64u);
  EXPECT_EQ(f->height, 48u);
  EXPECT_EQ(f->epoch, Epoch(7));
  EXPECT_DOUBLE_EQ(f->fx, 40.0);
  EXPECT_DOUBLE_EQ(f->cy, 23.5);
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) EXPECT_NEAR(f->camera_to_world[c][r], plane.poses[1][c][r], 1e-15) << c << "," << r;
  // Depth is 1/6553.5 m per unit: metres back within half a unit.
  for (std::uint32_t v = 0; v < f->height; v += 7)
    for (std::uint32_t u = 0; u < f->width; u += 5)
      EXPECT_NEAR(f->depth[v * f->width + u], plane.depth(1, u, v), 0.5 / 6553.5 + 1e-6) << u << "," << v;
  // The JPEG colour, decoded (a uniform colour survives JPEG within a few levels).
  ASSERT_EQ(f->colour.width, 64u);
  for (std::size_t k = 0; k < f->colour.pixels.size(); k += 4 * 97) {
    EXPECT_NEAR(f->colour.pixels[k + 0], plane.colour.r, 3);
    EXPECT_NEAR(f->colour.pixels[k + 1], plane.colour.g, 3);
    EXPECT_NEAR(f->colour.pixels[k + 2], plane.colour.b, 3);
  }
}

TEST(RgbdReplica, FusedSurfaceLiesOnThePlane) {
  const auto plane = test::write_replica_plane(test::output_dir() / "replica_fuse");
  auto src = RgbdFolderSource::open(plane.folder);
  ASSERT_TRUE(src) << src.message();
  TsdfConfig cfg;
  cfg.voxel_size = 0.05f;
  auto vol = TsdfVolume::create(cfg);
  ASSERT_TRUE(vol);
  for (std::size_t i = 0; i < src->frame_count(); ++i) {
    auto f = src->load(i, Epoch(i + 1));
    ASSERT_TRUE(f) << f.message();
    ASSERT_TRUE(vol->integrate(*f)) << src->frame_name(i);
  }
  const TriangleMesh mesh = vol->extract_all();
  ASSERT_GT(mesh.indices.size(), 3u * 500u) << "a 4 x 3 m plane at 5 cm voxels";
  std::vector<double> dist;
  for (std::size_t k = 0; k < mesh.positions.size(); ++k) {
    const glm::dvec3 p(mesh.positions[k]);
    dist.push_back(std::abs(plane.distance(p)));
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(p[a], plane.lo[a] - cfg.voxel_size) << "vertex " << k << " axis " << a;
      EXPECT_LE(p[a], plane.hi[a] + cfg.voxel_size) << "vertex " << k << " axis " << a;
    }
    EXPECT_NEAR(mesh.colors[k].r, plane.colour.r, 4);
    EXPECT_NEAR(mesh.colors[k].g, plane.colour.g, 4);
    EXPECT_NEAR(mesh.colors[k].b, plane.colour.b, 4);
  }
  std::sort(dist.begin(), dist.end());
  const double median = dist[dist.size() / 2], p99 = dist[dist.size() * 99 / 100], worst = dist.back();
  // Measured (5 cm voxels, 3 frames, 13.7k vertices): median 2.9 mm, p99 16 mm, max 25 mm.
  // Projective distances read the depth of the pixel a voxel falls in: at 4 m a pixel spans
  // 10 cm of the tilted plane, whose depth changes by ~3 cm across it, and the frustum's
  // edges are seen by one frame only; that bounds how far the zero crossing moves.
  const std::string figures = "|distance to the plane|: median " + std::to_string(median) + " m, p99 " +
                              std::to_string(p99) + " m, max " + std::to_string(worst) + " m";
  EXPECT_LT(median, 0.1 * cfg.voxel_size) << figures;
  EXPECT_LT(p99, 0.4 * cfg.voxel_size) << figures;
  EXPECT_LT(worst, 0.6 * cfg.voxel_size) << figures;
}

TEST(RgbdReplica, CamParamsMayLieInTheParentFolder) {
  const fs::path root = test::output_dir() / "replica_parent";
  fs::remove_all(root);
  const auto plane = test::write_replica_plane(root / "room0", 2, /*params_in_parent=*/true);
  ASSERT_FALSE(fs::exists(plane.folder / "cam_params.json"));
  auto src = RgbdFolderSource::open(plane.folder);
  ASSERT_TRUE(src) << src.message();
  EXPECT_EQ(src->frame_count(), 2u);
  fs::remove(root / "cam_params.json");
  auto none = RgbdFolderSource::open(plane.folder);
  ASSERT_FALSE(none);
  EXPECT_HAS(none.message(), "without cam_params.json");
}

TEST(RgbdReplica, MissingOrMalformedPosesNameTheFrameAndLine) {
  const auto plane = test::write_replica_plane(test::output_dir() / "replica_traj");
  // Keep two of the three poses, and break the second.
  std::ifstream in(plane.folder / "traj.txt");
  std::string first, second;
  std::getline(in, first);
  std::getline(in, second);
  in.close();
  std::ofstream(plane.folder / "traj.txt") << first << "\n" << second.substr(0, second.size() / 2) << " x 1\n\n";
  auto src = RgbdFolderSource::open(plane.folder);
  ASSERT_TRUE(src) << src.message() << ": listing still works, the frames fail on their own";
  ASSERT_EQ(src->frame_count(), 3u);
  EXPECT_TRUE(src->load(0, Epoch(1)));
  auto bad = src->load(1, Epoch(2));
  ASSERT_FALSE(bad);
  EXPECT_HAS(bad.message(), "frame000001");
  EXPECT_HAS(bad.message(), "traj.txt line 2");
  EXPECT_HAS(bad.message(), "('x') is not a finite number");
  auto missing = src->load(2, Epoch(3));
  ASSERT_FALSE(missing);
  EXPECT_HAS(missing.message(), "frame000002");
  EXPECT_HAS(missing.message(), "no pose");
  EXPECT_HAS(missing.message(), "has 2 poses and frame 2 needs line 3");
}

TEST(RgbdReplica, WrongImagesNameTheFile) {
  const auto plane = test::write_replica_plane(test::output_dir() / "replica_images");
  const fs::path results = plane.folder / "results";
  ImageRGBA8 small;
  small.width = 32;
  small.height = 24;
  small.pixels.assign(32 * 24 * 4, 128);
  // Colour of another size than its depth.
  ASSERT_TRUE(write_jpeg(results / "frame000001.jpg", small));
  // An 8-bit PNG where a 16-bit depth image belongs, and a JPEG under a .png name.
  ASSERT_TRUE(write_png(results / "depth000000.png", small));
  fs::copy_file(results / "frame000001.jpg", results / "depth000002.png", fs::copy_options::overwrite_existing);
  auto src = RgbdFolderSource::open(plane.folder);
  ASSERT_TRUE(src) << src.message();
  auto eight = src->load(0, Epoch(1));
  ASSERT_FALSE(eight);
  EXPECT_HAS(eight.message(), "depth000000.png");
  EXPECT_HAS(eight.message(), "expected a 16-bit PNG, found 8-bit samples");
  auto sizes = src->load(1, Epoch(1));
  ASSERT_FALSE(sizes);
  EXPECT_HAS(sizes.message(), "frame000001.jpg: colour image is 32x24 but its depth image is 64x48");
  auto jpeg = src->load(2, Epoch(1));
  ASSERT_FALSE(jpeg);
  EXPECT_HAS(jpeg.message(), "depth000002.png: cannot read PNG: the file is a JPEG");
  // A 16-bit depth image of another size than cam_params.json says.
  ImageU16 depth;
  depth.width = 32;
  depth.height = 24;
  depth.pixels.assign(32 * 24, 10000);
  ASSERT_TRUE(write_png_u16(results / "depth000000.png", depth));
  auto other = src->load(0, Epoch(1));
  ASSERT_FALSE(other);
  EXPECT_HAS(other.message(), "depth000000.png: depth image is 32x24 but cam_params.json says 64x48");
}

TEST(RgbdReplica, BadCamParamsNameTheFileAndMember) {
  const auto plane = test::write_replica_plane(test::output_dir() / "replica_params", 1);
  const fs::path params = plane.folder / "cam_params.json";
  const auto open_with = [&](const std::string& text) {
    std::ofstream(params) << text;
    auto src = RgbdFolderSource::open(plane.folder);
    EXPECT_FALSE(src) << text;
    return src ? std::string{} : src.message();
  };
  std::string m = open_with("{\"camera\": {\"w\": 64, \"h\": 48,");
  EXPECT_HAS(m, "cam_params.json: not valid JSON");
  m = open_with("{\"w\": 64}");
  EXPECT_HAS(m, "cam_params.json: expected an object {\"camera\"");
  m = open_with(R"({"camera": {"w": 64, "h": 48, "fx": 40, "fy": 40, "cx": 31.5, "cy": 23.5}})");
  EXPECT_HAS(m, "cam_params.json: camera.scale is missing");
  m = open_with(R"({"camera": {"w": 64, "h": 48, "fx": "40", "fy": 40, "cx": 31.5, "cy": 23.5, "scale": 1}})");
  EXPECT_HAS(m, "camera.fx is not a finite number");
  m = open_with(R"({"camera": {"w": 64, "h": 48, "fx": -40, "fy": 40, "cx": 31.5, "cy": 23.5, "scale": 1}})");
  EXPECT_HAS(m, "camera.fx and camera.fy must be > 0");
  m = open_with(R"({"camera": {"w": 64.5, "h": 48, "fx": 40, "fy": 40, "cx": 31.5, "cy": 23.5, "scale": 1}})");
  EXPECT_HAS(m, "camera.w and camera.h must be whole numbers");
  m = open_with(R"({"camera": {"w": 64, "h": 48, "fx": 40, "fy": 40, "cx": 31.5, "cy": 23.5, "scale": 0}})");
  EXPECT_HAS(m, "camera.scale (depth units per metre) must be > 0");
}

TEST(RgbdReplica, AFolderWithoutDepthImagesHasNoFrames) {
  const auto plane = test::write_replica_plane(test::output_dir() / "replica_empty", 1);
  fs::remove_all(plane.folder / "results");
  fs::create_directories(plane.folder / "results");
  auto src = RgbdFolderSource::open(plane.folder);
  ASSERT_FALSE(src);
  EXPECT_HAS(src.message(), "no RGB-D frames found (Replica layout)");
  // Without results/ the folder is not recognised as Replica: the message lists the layouts.
  fs::remove_all(plane.folder / "results");
  auto none = RgbdFolderSource::open(plane.folder);
  ASSERT_FALSE(none);
  EXPECT_HAS(none.message(), "a Replica folder (traj.txt, results/)");
}

}  // namespace
}  // namespace gauss
