// A trainer writing into a folder while gauss-host follows it (--scene FOLDER) and a
// gauss-view --headless client watches: the first snapshot is served, a second one written
// in two halves is waited for (not skipped as corrupt) and served once complete, a third
// one follows; the client publishes each epoch and ends holding exactly the last snapshot.
#include <algorithm>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "child_process.h"
#include "e2e_support.h"
#include "gauss/engine/ply_gaussian.h"

namespace {

using namespace std::chrono_literals;
using gauss::test::read_text;
namespace fs = std::filesystem;

constexpr const char* kPath = R"({
  "camera": {"width": 160, "height": 120, "fx": 100, "fy": 100, "cx": 80, "cy": 60},
  "fps": 10,
  "keyframes": [{"t": 0.0, "eye": [0, 0, -4], "look_at": [0, 0, 0]}, {"t": 1.0, "eye": [0, 0.2, -4], "look_at": [0, 0, 0]}]
})";

// A grid of `n` small Gaussians with persistent ids first_id.. (a trainer writing ids).
std::vector<std::uint8_t> snapshot(std::size_t n, std::uint64_t first_id, float colour) {
  gauss::GaussianCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    gauss::Gaussian g;
    g.position = {static_cast<float>(i % 40) * 0.05f - 1.0f, static_cast<float>(i / 40) * 0.05f - 1.0f, 0.0f};
    g.log_scale = glm::vec3(std::log(0.02f));
    g.opacity_logit = 2.0f;
    g.sh_dc = {colour, 0.2f, 0.3f};
    g.id = gauss::GaussianId{first_id + i};
    c.gaussians.push_back(g);
  }
  gauss::PlyGaussianWriteOptions o;
  o.write_gaussian_id = true;
  auto bytes = gauss::encode_gaussian_ply(c, o);
  EXPECT_TRUE(bytes.ok()) << bytes.message();
  return bytes.ok() ? *bytes : std::vector<std::uint8_t>{};
}

void write_bytes(const fs::path& p, const std::uint8_t* data, std::size_t n) {
  std::ofstream f(p, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(n));
}

// Waits until `log` contains `text` (the host prints a status line every second).
bool wait_for_text(const fs::path& log, const std::string& text, std::chrono::seconds limit) {
  for (auto t0 = std::chrono::steady_clock::now(); std::chrono::steady_clock::now() - t0 < limit;) {
    if (read_text(log).find(text) != std::string::npos) return true;
    std::this_thread::sleep_for(100ms);
  }
  return false;
}

TEST(HostSnapshotFolder, EachNewSnapshotStreamsToTheClientAndAHalfWrittenOneIsWaitedFor) {
  const fs::path out = fs::path(GAUSS_TEST_OUTPUT_DIR) / "e2e_host_snapshot_folder";
  const fs::path folder = out / "trainer";
  fs::remove_all(out);
  fs::create_directories(folder);
  std::ofstream(out / "path.json") << kPath;
  const auto s1 = snapshot(1200, 1, 0.5f);
  write_bytes(folder / "snap_1.ply", s1.data(), s1.size());

  gauss::test::ChildProcess host;
  std::string endpoint;
  for (int attempt = 0; attempt < 3 && endpoint.empty(); ++attempt) {
    const std::string ep = "127.0.0.1:" + std::to_string(gauss::test::free_udp_port());
    ASSERT_TRUE(host.start({GAUSS_HOST_EXE, "--bind", ep, "--scene", folder.string(), "--epoch-period", "0.2",
                            "--settle", "60", "--duration", "300"},
                           out / "host.log"));
    if (!host.wait(700ms)) endpoint = ep;
  }
  ASSERT_FALSE(endpoint.empty()) << read_text(out / "host.log");

  gauss::test::ChildProcess view;
  ASSERT_TRUE(view.start({GAUSS_VIEW_EXE, "--headless", "--host", endpoint, "--path", (out / "path.json").string(),
                          "--out", (out / "view").string(), "--budget", "5000", "--every", "1000",
                          "--settle-timeout", "120", "--quiet-time", "6"},
                         out / "view.log"));
  ASSERT_TRUE(wait_for_text(out / "host.log", "clients 1", 60s)) << read_text(out / "host.log");

  // The trainer writes snapshot 2 in two halves, a second apart.
  const auto s2 = snapshot(1500, 1, 0.7f);  // the same ids moved on, and 300 new ones
  write_bytes(folder / "snap_2.ply", s2.data(), s2.size() / 2);
  ASSERT_TRUE(wait_for_text(out / "host.log", "waiting for", 30s)) << read_text(out / "host.log");
  std::this_thread::sleep_for(1s);
  write_bytes(folder / "snap_2.ply", s2.data(), s2.size());
  ASSERT_TRUE(wait_for_text(out / "host.log", "epoch 2", 30s)) << read_text(out / "host.log");
  const auto s3 = snapshot(900, 301, 0.9f);  // 300 pruned
  write_bytes(folder / "snap_3.ply", s3.data(), s3.size());

  const auto view_rc = view.wait(240s);
  if (!view_rc) view.stop(SIGKILL);
  ASSERT_EQ(view_rc.value_or(-1), 0) << read_text(out / "view.log");
  const auto host_rc = host.stop(SIGINT);
  const std::string host_log = read_text(out / "host.log");
  EXPECT_EQ(host_rc.value_or(-1), 0) << host_log;
  EXPECT_EQ(host_log.find("skipped snapshot"), std::string::npos) << host_log;
  EXPECT_NE(host_log.find("stopping after"), std::string::npos) << "a summary on exit:\n" << host_log;

  std::set<std::uint64_t> epochs;
  std::istringstream frames(read_text(out / "view" / "frames.jsonl"));
  for (std::string line; std::getline(frames, line);) {
    const auto j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_object() && j.contains("published_epoch") && j["published_epoch"].is_number())
      epochs.insert(j["published_epoch"].get<std::uint64_t>());
  }
  EXPECT_TRUE(epochs.count(1) && epochs.count(2) && epochs.count(3)) << "published epochs seen: " << epochs.size();
  const auto summary = nlohmann::json::parse(read_text(out / "view" / "summary.json"));
  EXPECT_TRUE(summary["settled"].get<bool>()) << summary.dump(2);
  EXPECT_EQ(summary["resident"].get<std::uint64_t>(), 900u) << summary.dump(2);
  EXPECT_EQ(summary["published_epoch"].get<std::uint64_t>(), 3u) << summary.dump(2);
}

}  // namespace
