// gauss-fuse, the real program as a child process: the SUN3D sample and a hand-made Replica
// capture fused into PLY meshes that are read back and checked against their input, and bad
// folders, frames and arguments failing with a message that names them and a non-zero exit.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <glm/common.hpp>

#include "child_process.h"
#include "gauss/engine/ply_mesh.h"
#include "gauss/engine/rgbd_source.h"
#include "replica_fixture.h"
#include "test_data.h"

namespace gauss {
namespace {
namespace fs = std::filesystem;
using namespace std::chrono_literals;

#define EXPECT_HAS(text, part) EXPECT_NE((text).find(part), std::string::npos) << (text)

struct FuseRun {
  int rc{-1};
  std::string output;  // stdout and stderr together
};

// Runs gauss-fuse with `args`; its output goes to <test-output>/<log>.
FuseRun fuse(const std::vector<std::string>& args, const std::string& log) {
  const fs::path log_path = test::output_dir() / log;
  fs::remove(log_path);
  std::vector<std::string> argv{GAUSS_FUSE_EXE};
  argv.insert(argv.end(), args.begin(), args.end());
  test::ChildProcess child;
  FuseRun r;
  if (!child.start(argv, log_path)) {
    ADD_FAILURE() << "cannot start " << GAUSS_FUSE_EXE;
    return r;
  }
  // Seconds in a release build; the sanitizer build is many times slower.
  const auto rc = child.wait(300s);
  if (!rc) child.stop(SIGKILL);
  r.rc = rc.value_or(-1);
  std::ifstream in(log_path);
  std::stringstream ss;
  ss << in.rdbuf();
  r.output = ss.str();
  return r;
}

struct Box {
  glm::dvec3 lo{std::numeric_limits<double>::max()}, hi{-std::numeric_limits<double>::max()};
  void add(const glm::dvec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
};

TEST(FuseCli, FusesTheSun3dSample) {
  GAUSS_REQUIRE_DATA(folder, "rgbd/sun3d_studyroom");
  const fs::path out = test::output_dir() / "fuse_sun3d.ply";
  fs::remove(out);
  const FuseRun r = fuse({"--rgbd", folder.string(), "--out", out.string()}, "fuse_sun3d.log");
  ASSERT_EQ(r.rc, 0) << r.output;
  EXPECT_HAS(r.output, "3DMatch layout, 5 frames listed");
  EXPECT_HAS(r.output, "frames     5 fused, 0 skipped");
  auto mesh = read_mesh_ply(out);
  ASSERT_TRUE(mesh) << mesh.message();
  const std::size_t triangles = mesh->mesh.indices.size() / 3;
  EXPECT_HAS(r.output, std::to_string(mesh->mesh.positions.size()) + " vertices, " + std::to_string(triangles) +
                           " triangles");
  EXPECT_GT(triangles, 100000u) << "five 640x480 frames of a room at 2 cm voxels";
  EXPECT_TRUE(mesh->report.has_colors);

  // Expected bounds: the world points of every usable depth pixel (0.1..8 m). The mesh lies
  // within them (widened by the truncation band and a voxel) and spans nearly all of them.
  auto src = RgbdFolderSource::open(folder);
  ASSERT_TRUE(src) << src.message();
  Box input;
  std::vector<double> axis[3];
  for (std::size_t i = 0; i < src->frame_count(); ++i) {
    auto f = src->load(i, Epoch(1));
    ASSERT_TRUE(f) << f.message();
    const glm::dmat3 R(f->camera_to_world);
    const glm::dvec3 C(f->camera_to_world[3]);
    for (std::uint32_t v = 0; v < f->height; ++v)
      for (std::uint32_t u = 0; u < f->width; ++u) {
        const double d = f->depth[std::size_t(v) * f->width + u];
        if (!(d >= 0.1 && d <= 8.0)) continue;
        const glm::dvec3 p = C + R * glm::dvec3((u + 0.5 - f->cx) / f->fx * d, (v + 0.5 - f->cy) / f->fy * d, d);
        input.add(p);
        if ((u + v) % 7 == 0)
          for (int a = 0; a < 3; ++a) axis[a].push_back(p[a]);
      }
  }
  Box fused;
  for (const glm::vec3& p : mesh->mesh.positions) fused.add(glm::dvec3(p));
  const double margin = 0.06 + 0.02;  // truncation (3 voxels) + a voxel
  for (int a = 0; a < 3; ++a) {
    EXPECT_GE(fused.lo[a], input.lo[a] - margin) << "axis " << a;
    EXPECT_LE(fused.hi[a], input.hi[a] + margin) << "axis " << a;
    // Spans the bulk of the input: its 1st to 99th percentile on each axis.
    std::sort(axis[a].begin(), axis[a].end());
    EXPECT_LE(fused.lo[a], axis[a][axis[a].size() / 100]) << "axis " << a;
    EXPECT_GE(fused.hi[a], axis[a][axis[a].size() * 99 / 100]) << "axis " << a;
  }
}

TEST(FuseCli, FusesAHandMadeReplicaCaptureOntoItsPlane) {
  const auto plane = test::write_replica_plane(test::output_dir() / "fuse_replica" / "room0", 4);
  const fs::path out = test::output_dir() / "fuse_replica.ply";
  fs::remove(out);
  const double voxel = 0.05;
  const FuseRun r = fuse({"--rgbd", plane.folder.string(), "-o", out.string(), "--voxel-size", "0.05", "--ascii"},
                     "fuse_replica.log");
  ASSERT_EQ(r.rc, 0) << r.output;
  EXPECT_HAS(r.output, "Replica layout, 4 frames listed, fusing 4");
  auto mesh = read_mesh_ply(out);
  ASSERT_TRUE(mesh) << mesh.message();
  EXPECT_EQ(mesh->report.format, PlyFormat::Ascii);
  ASSERT_GT(mesh->mesh.indices.size(), 3u * 1000u);
  double worst = 0.0;
  for (const glm::vec3& q : mesh->mesh.positions) {
    const glm::dvec3 p(q);
    worst = std::max(worst, std::abs(plane.distance(p)));
    for (int a = 0; a < 3; ++a) {
      ASSERT_GE(p[a], plane.lo[a] - voxel) << "axis " << a;
      ASSERT_LE(p[a], plane.hi[a] + voxel) << "axis " << a;
    }
  }
  EXPECT_LT(worst, 0.6 * voxel) << "max |distance to the plane| (see engine_rgbd_replica for the figures)";

  // --first / --stride / --frames pick frames 1 and 3.
  const FuseRun some = fuse({"--rgbd", plane.folder.string(), "-o", out.string(), "--voxel-size", "0.05", "--first",
                             "1", "--stride", "2", "--frames", "5"},
                            "fuse_replica_some.log");
  ASSERT_EQ(some.rc, 0) << some.output;
  EXPECT_HAS(some.output, "fusing 2 (first 1, stride 2)");
  EXPECT_HAS(some.output, "frames     2 fused, 0 skipped, of 4 listed");
}

TEST(FuseCli, BadFoldersFramesAndArgumentsFailClearly) {
  const fs::path root = test::output_dir() / "fuse_bad";
  fs::remove_all(root);
  fs::create_directories(root / "empty");
  const fs::path out = root / "out.ply";

  // A folder of no known layout: exit 1, the message lists the layouts and names the folder.
  FuseRun r = fuse({"--rgbd", (root / "empty").string(), "-o", out.string()}, "fuse_bad_empty.log");
  EXPECT_EQ(r.rc, 1) << r.output;
  EXPECT_HAS(r.output, "fuse_bad/empty: neither a TUM folder");
  EXPECT_HAS(r.output, "camera-intrinsics.txt");
  // No folder at all: a usage error naming the option.
  r = fuse({"--rgbd", (root / "absent").string(), "-o", out.string()}, "fuse_bad_absent.log");
  EXPECT_EQ(r.rc, 2) << r.output;
  EXPECT_HAS(r.output, "--rgbd");

  // A Replica capture whose traj.txt ends one pose early: the frame is named, exit 1,
  // nothing written; with --skip-bad the others are fused.
  const auto plane = test::write_replica_plane(root / "short", 3);
  {
    std::ifstream in(plane.folder / "traj.txt");
    std::string a, b;
    std::getline(in, a);
    std::getline(in, b);
    in.close();
    std::ofstream(plane.folder / "traj.txt") << a << "\n" << b << "\n";
  }
  r = fuse({"--rgbd", plane.folder.string(), "-o", out.string(), "--voxel-size", "0.05"}, "fuse_bad_traj.log");
  EXPECT_EQ(r.rc, 1) << r.output;
  EXPECT_HAS(r.output, "frame000002': no pose");
  EXPECT_HAS(r.output, "--skip-bad");
  EXPECT_FALSE(fs::exists(out));
  r = fuse({"--rgbd", plane.folder.string(), "-o", out.string(), "--voxel-size", "0.05", "--skip-bad"},
           "fuse_bad_skip.log");
  EXPECT_EQ(r.rc, 0) << r.output;
  EXPECT_HAS(r.output, "skipped: RGB-D frame");
  EXPECT_HAS(r.output, "frames     2 fused, 1 skipped, of 3 listed");
  EXPECT_TRUE(fs::exists(out));

  // Arguments: --first past the end, an empty depth range, an unwritable output.
  r = fuse({"--rgbd", plane.folder.string(), "-o", out.string(), "--first", "3"}, "fuse_bad_first.log");
  EXPECT_EQ(r.rc, 2) << r.output;
  EXPECT_HAS(r.output, "--first: 3 is past the last frame");
  r = fuse({"--rgbd", plane.folder.string(), "-o", out.string(), "--min-depth", "2", "--max-depth", "1"},
           "fuse_bad_depth.log");
  EXPECT_EQ(r.rc, 2) << r.output;
  EXPECT_HAS(r.output, "--max-depth");
  r = fuse({"--rgbd", plane.folder.string(), "-o", (root / "no_such_dir" / "m.ply").string(), "--voxel-size", "0.05",
            "--skip-bad"},
           "fuse_bad_out.log");
  EXPECT_EQ(r.rc, 1) << r.output;
  EXPECT_HAS(r.output, "no_such_dir");
  // Every depth beyond --max-depth: nothing to mesh, said so.
  r = fuse({"--rgbd", plane.folder.string(), "-o", out.string(), "--max-depth", "0.5", "--skip-bad"},
           "fuse_bad_range.log");
  EXPECT_EQ(r.rc, 1) << r.output;
  EXPECT_HAS(r.output, "is empty");
}

}  // namespace
}  // namespace gauss
