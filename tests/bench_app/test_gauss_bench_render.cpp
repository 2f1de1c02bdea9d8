// gauss-bench render as a user runs it, on a tiny size: a box row and a capture@WxH row of a
// real capture (guitar.ply of the shared data), each within the reference tolerance of the
// CPU reference, the capture placed in view; with --peer, the peer is handed the placed
// capture as a PLY it can read (SH 3 layout, every Gaussian in front of the camera). The
// peer here is a stand-in script that keeps the file and prints a time. And a capture row
// without --capture is refused by name. Timing is never checked.
#include <algorithm>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "child_process.h"
#include "test_data.h"
#include "text_file.h"
#include "gauss/engine/ply_gaussian.h"

namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

int run_bench(const std::vector<std::string>& args, const fs::path& log) {
  std::vector<std::string> argv = {GAUSS_BENCH_EXE, "render"};
  argv.insert(argv.end(), args.begin(), args.end());
  fs::remove(log);
  gauss::test::ChildProcess bench;
  EXPECT_TRUE(bench.start(argv, log));
  const auto rc = bench.wait(240s);
  if (!rc) bench.stop(SIGKILL);
  return rc.value_or(-1);
}

// Checks a row's comparison with the CPU reference: PSNR >= 60 dB ("inf" counts), max <= 2.
void expect_close_to_reference(const nlohmann::json& row) {
  ASSERT_TRUE(row.contains("reference")) << row.dump();
  const auto& psnr = row["reference"]["psnr_db"];
  EXPECT_TRUE(psnr.is_string() ? psnr.get<std::string>() == "inf" : psnr.get<double>() >= 60.0) << row.dump();
  EXPECT_LE(row["reference"]["max_abs_error"].get<int>(), 2) << row.dump();
}

TEST(GaussBenchRender, BoxAndCaptureRowsMatchTheReference) {
  GAUSS_REQUIRE_DATA(guitar, "splats/guitar.ply");
  const fs::path out = gauss::test::output_dir() / "bench_app_render";
  fs::create_directories(out);
  ASSERT_EQ(run_bench({"--sizes", "2k@64x48,capture@64x48", "--capture", guitar.string(), "--frames", "1", "--json",
                       (out / "render.json").string()},
                      out / "render.log"),
            0)
      << gauss::test::read_text(out / "render.log");
  const auto doc = nlohmann::json::parse(gauss::test::read_text(out / "render.json"));
  ASSERT_EQ(doc["results"].size(), 2u) << doc.dump();
  const auto& box = doc["results"][0];
  const auto& capture = doc["results"][1];
  EXPECT_EQ(box["n"].get<long>(), 2000);
  expect_close_to_reference(box);
  EXPECT_EQ(capture["n"].get<long>(), 90854);
  EXPECT_EQ(capture["capture"].get<std::string>(), guitar.string());
  expect_close_to_reference(capture);
  // Placed in view: nearly every Gaussian of the capture reaches a tile.
  EXPECT_GT(capture["visible"].get<long>(), 85000) << capture.dump();
  EXPECT_NE(gauss::test::read_text(out / "render.log").find("up -y turned to +y"), std::string::npos);
}

TEST(GaussBenchRender, ThePeerGetsThePlacedCaptureInItsLayout) {
  GAUSS_REQUIRE_DATA(guitar, "splats/guitar.ply");
  const fs::path out = gauss::test::output_dir() / "bench_app_peer";
  fs::remove_all(out);
  fs::create_directories(out);
  // A stand-in for the peer: keeps the scene it is given and prints the line gauss-bench reads.
  const fs::path peer = out / "peer.sh";
  {
    std::ofstream f(peer);
    f << "#!/bin/sh\ncp \"$1\" '" << (out / "given.ply").string() << "'\necho 'median_wall_ms 1.5 | render 1.0'\n";
  }
  fs::permissions(peer, fs::perms::owner_all);
  ASSERT_EQ(run_bench({"--sizes", "capture@64x48", "--capture", guitar.string(), "--frames", "1", "--no-reference",
                       "--peer", peer.string(), "--peer-rounds", "1", "--json", (out / "peer.json").string()},
                      out / "peer.log"),
            0)
      << gauss::test::read_text(out / "peer.log");
  auto given = gauss::read_gaussian_ply(out / "given.ply");
  ASSERT_TRUE(given.ok()) << given.message();
  EXPECT_EQ(given->cloud.sh_degree, 3);  // the peer's loader reads all 45 rest coefficients
  ASSERT_EQ(given->cloud.gaussians.size(), 90854u);
  EXPECT_TRUE(std::all_of(given->cloud.gaussians.begin(), given->cloud.gaussians.end(),
                          [](const gauss::Gaussian& g) { return g.position.z < 0.0f; }))
      << "the peer's camera looks down -z from the origin";
  const auto doc = nlohmann::json::parse(gauss::test::read_text(out / "peer.json"));
  EXPECT_DOUBLE_EQ(doc["peer"]["sizes"][0]["peer_ms"].get<double>(), 1.5) << doc.dump();
}

TEST(GaussBenchRender, ACaptureRowNeedsACaptureFile) {
  const fs::path out = gauss::test::output_dir() / "bench_app_no_capture";
  fs::create_directories(out);
  EXPECT_NE(run_bench({"--sizes", "capture@64x48", "--frames", "1"}, out / "log.txt"), 0);
  EXPECT_NE(gauss::test::read_text(out / "log.txt").find("capture@64x48 needs --capture FILE"), std::string::npos)
      << gauss::test::read_text(out / "log.txt");
}

}  // namespace
