// Opening a scene file for a viewer (scene_load.h): the load on the caller's thread and on
// a job's, its progress (bytes read, then decoding, then done), its bounds, a reader's
// error passed through naming the file; and the never-overwriting numbered files a viewer
// writes its screenshots to (numbered_file.h).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/engine/numbered_file.h"
#include "gauss/engine/ply_gaussian.h"
#include "gauss/engine/scene_load.h"
#include "address_space_limit.h"
#include "test_data.h"

namespace gauss {
namespace {

namespace fs = std::filesystem;

// `n` Gaussians on a line along x from 0 to n - 1 (y = 2, z = -3), opaque.
GaussianCloud line(std::size_t n) {
  GaussianCloud cloud;
  for (std::size_t i = 0; i < n; ++i) {
    Gaussian g;
    g.position = {static_cast<float>(i), 2.0f, -3.0f};
    g.opacity_logit = 4.0f;
    g.id = GaussianId{i + 1};
    cloud.gaussians.push_back(g);
  }
  return cloud;
}

TEST(SceneLoad, LoadsAPlyWithItsBoundsAndUp) {
  const fs::path ply = test::fresh_output_dir("scene_load/load") / "line.ply";
  ASSERT_TRUE(write_gaussian_ply(ply, line(101)).ok());
  SceneLoadProgress progress;
  auto loaded = load_scene_file(ply, std::nullopt, &progress);
  ASSERT_TRUE(loaded.ok()) << loaded.message();
  EXPECT_EQ(loaded->path, ply);
  EXPECT_EQ(loaded->scene.cloud.gaussians.size(), 101u);
  EXPECT_EQ(loaded->scene.report.format, SplatFormat::InriaPly);
  EXPECT_EQ(loaded->file_bytes, fs::file_size(ply));
  EXPECT_EQ(progress.bytes_total(), fs::file_size(ply));
  EXPECT_DOUBLE_EQ(progress.read_fraction(), 1.0);
  EXPECT_EQ(progress.phase(), SceneLoadPhase::Bounds);  // Done is the job's to say
  // Full bounds: every centre; robust: the 2..98 % cut of x, the constant y and z.
  EXPECT_EQ(loaded->full.finite, 101u);
  EXPECT_EQ(loaded->full.lo, glm::dvec3(0.0, 2.0, -3.0));
  EXPECT_EQ(loaded->full.hi, glm::dvec3(100.0, 2.0, -3.0));
  EXPECT_NEAR(loaded->robust.lo.x, 2.0, 1.0);
  EXPECT_NEAR(loaded->robust.hi.x, 98.0, 1.0);
  EXPECT_EQ(loaded->up.source, UpSource::Default);
  EXPECT_GE(loaded->load_s, 0.0);
  auto up = load_scene_file(ply, glm::dvec3(0.0, 0.0, 1.0));
  ASSERT_TRUE(up.ok());
  EXPECT_EQ(up->up.source, UpSource::Option);
}

TEST(SceneLoad, JobReadsALargeFileInPiecesOffTheCallersThread) {
  // More than one kReadChunkBytes piece (4 MiB): the counter advances per piece.
  const fs::path ply = test::fresh_output_dir("scene_load/job") / "large.ply";
  ASSERT_TRUE(write_gaussian_ply(ply, line(120000)).ok());
  ASSERT_GT(fs::file_size(ply), std::uintmax_t{4} << 20);
  SceneLoadJob job(ply, std::nullopt);
  EXPECT_EQ(job.path(), ply);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!job.ready() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_TRUE(job.ready());
  EXPECT_EQ(job.progress().phase(), SceneLoadPhase::Done);
  EXPECT_DOUBLE_EQ(job.progress().read_fraction(), 1.0);
  auto loaded = job.take();
  ASSERT_TRUE(loaded.ok()) << loaded.message();
  EXPECT_EQ(loaded->scene.cloud.gaussians.size(), 120000u);
  auto again = job.take();
  ASSERT_FALSE(again.ok());
  EXPECT_NE(again.message().find("already taken"), std::string::npos) << again.message();
}

TEST(SceneLoad, ReadersErrorsNameTheFile) {
  const fs::path dir = test::fresh_output_dir("scene_load/errors");
  const fs::path garbage = dir / "garbage.ply";
  {
    std::ofstream out(garbage, std::ios::binary);
    out << std::string(1000, '\x7f');
  }
  SceneLoadJob job(garbage, std::nullopt);
  auto bad = job.take();  // waits
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.message().rfind(garbage.string(), 0), 0u) << bad.message();
  EXPECT_TRUE(job.ready());

  auto missing = load_scene_file(dir / "missing.ply", std::nullopt);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.message().find("missing.ply"), std::string::npos) << missing.message();

  // A scene with no Gaussians has nothing to show: refused here, for every caller.
  const fs::path empty = dir / "empty.ply";
  ASSERT_TRUE(write_gaussian_ply(empty, GaussianCloud{}).ok());
  auto none = load_scene_file(empty, std::nullopt);
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.message().find("no Gaussians"), std::string::npos) << none.message();
}

// A scene larger than the process may hold (a container's limit, ulimit -v, a small machine):
// an error with the figures from the loading thread, where the allocation ended the viewer
// with the scene it still showed. In a child under an address-space limit.
TEST(SceneLoad, AFileTooLargeForTheProcessIsAnErrorWithTheFigures) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "ASan reserves more address space than the limit this test sets";
#else
  const fs::path ply = test::fresh_output_dir("scene_load/memory") / "large.ply";
  ASSERT_TRUE(write_gaussian_ply(ply, line(200000)).ok());  // 14 MB on disk, 53 MB read
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        const auto says = [](const Expected<LoadedScene>& r, const std::string& what) {
          if (r.ok()) return false;
          std::fprintf(stderr, "%s\n", r.message().c_str());
          return r.message().find(what) != std::string::npos &&
                 r.message().find("the address-space limit (ulimit -v)") != std::string::npos;
        };
        {
          // Room for the file's bytes, not for its Gaussians.
          test::AddressSpaceLimit limit(std::size_t{30} << 20);
          if (!limit.set()) std::_Exit(2);
          SceneLoadJob job(ply, std::nullopt);
          if (!says(job.take(), "large.ply: not enough memory: 200000 Gaussians need about")) std::_Exit(3);
        }
        {
          test::AddressSpaceLimit limit(std::size_t{8} << 20);  // not even for the bytes
          if (!limit.set()) std::_Exit(4);
          if (!says(load_scene_file(ply, std::nullopt), "large.ply: not enough memory: its bytes need about"))
            std::_Exit(5);
        }
        auto loaded = load_scene_file(ply, std::nullopt);  // the limit lifted
        std::_Exit(loaded.ok() && loaded->scene.cloud.gaussians.size() == 200000 ? 0 : 6);
      },
      ::testing::ExitedWithCode(0), "");
#endif
}

TEST(SceneLoad, FullBoundsSkipNonFiniteCentres) {
  std::vector<Gaussian> gs(3);
  gs[0].position = {1.0f, -1.0f, 0.0f};
  gs[1].position = {std::numeric_limits<float>::quiet_NaN(), 5.0f, 5.0f};
  gs[2].position = {-2.0f, 4.0f, std::numeric_limits<float>::infinity()};
  FullBounds b = full_bounds(gs);
  EXPECT_EQ(b.finite, 1u);
  EXPECT_EQ(b.lo, glm::dvec3(1.0, -1.0, 0.0));
  EXPECT_EQ(b.hi, b.lo);
  FullBounds none = full_bounds(std::span<const Gaussian>(gs.data() + 1, 2));
  EXPECT_EQ(none.finite, 0u);
  EXPECT_EQ(none.lo, glm::dvec3(0.0));
}

TEST(NumberedFile, NeverOverwritesAndCountsUp) {
  const fs::path dir = test::fresh_output_dir("scene_load/numbered");
  {
    std::ofstream keep(dir / "shot-0002.png");
    keep << "keep";
  }
  auto a = create_numbered_file(dir, "shot", ".png");
  ASSERT_TRUE(a.ok()) << a.message();
  EXPECT_EQ(*a, dir / "shot-0001.png");
  EXPECT_TRUE(fs::exists(*a));
  auto b = create_numbered_file(dir, "shot", ".png");
  ASSERT_TRUE(b.ok()) << b.message();
  EXPECT_EQ(*b, dir / "shot-0003.png");  // 0002 exists and is left alone
  std::ifstream kept(dir / "shot-0002.png");
  std::string text;
  kept >> text;
  EXPECT_EQ(text, "keep");

  auto nowhere = create_numbered_file(dir / "no-such-folder", "shot", ".png");
  ASSERT_FALSE(nowhere.ok());
  EXPECT_NE(nowhere.message().find("no-such-folder"), std::string::npos) << nowhere.message();
}

}  // namespace
}  // namespace gauss
