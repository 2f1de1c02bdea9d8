// gauss-eval --realtime on a small configuration: gauss-host as a child process (the one
// built beside gauss-eval), the real client over loopback ENet, the wall clock. Its
// figures do not reproduce, so nothing is compared across runs; what must hold every
// time: it exits 0; at every view measured the client's frame equals the host's render of
// the set the host's dump says it sent (0 differing pixels), the client published exactly
// that set, and it is the evaluation's own scene; each semantic query, sent once the client
// settled without it, holds exactly min(|G_obj|, floor(rho M)) of its M slots, its stages
// logged in order; every view converged; no validation
// error; and the gauss-host process it started is gone afterwards. Also the refusals: a
// contradictory command line (exit 2) and a missing host executable (exit 1, named).
#include <signal.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "child_process.h"
#include "text_file.h"

namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

using gauss::test::read_text;

// One room of 8000 Gaussians at M = 2000, one camera at 96x72: about 10 s on lavapipe (2
// cores), most of it the five connections settling. The quiet window (0.5 s) leaves the
// host time to answer a move (poses go out at 10 Hz) on a loaded machine.
std::vector<std::string> realtime_args(const fs::path& out) {
  return {GAUSS_EVAL_EXE, "--realtime", "--scenes", "0", "--gaussians", "8000", "--budget", "2000", "--size", "96x72",
          "--cameras", "1", "--quiet", "0.5", "--settle-timeout", "30", "--flicker-window", "1", "--name",
          "ctest-realtime", "--out", out.string()};
}

// Runs gauss-eval with `args` (its output to out/eval.log); its exit status.
int run_eval(const fs::path& out, const std::vector<std::string>& args, std::chrono::seconds limit) {
  fs::remove_all(out);
  fs::create_directories(out);
  gauss::test::ChildProcess eval;
  if (!eval.start(args, out / "eval.log")) return -1000;
  const auto rc = eval.wait(limit);
  if (!rc) eval.stop(SIGKILL);
  return rc.value_or(-1001);
}

// Whether a gauss-host still runs as `pid` (a reused pid running something else is not).
bool host_alive(pid_t pid) {
  if (::kill(pid, 0) != 0 && errno == ESRCH) return false;
  return read_text("/proc/" + std::to_string(pid) + "/cmdline").find("gauss-host") != std::string::npos;
}

TEST(GaussEvalRealtime, HostAndClientAsProcessesOverLoopbackMatchTheSentSet) {
  const fs::path out = fs::path(GAUSS_TEST_OUTPUT_DIR) / "eval_app_gauss_eval_realtime";
  ASSERT_EQ(run_eval(out, realtime_args(out), 180s), 0) << read_text(out / "eval.log");

  const nlohmann::json r = nlohmann::json::parse(read_text(out / "report.json"));
  EXPECT_TRUE(r["realtime"].get<bool>());
  EXPECT_TRUE(r.contains("timing")) << "realtime figures are wall-clock: timing is always there";
  EXPECT_EQ(r["validation_errors"].get<std::uint64_t>(), 0u);
  ASSERT_EQ(r["scenes"].size(), 1u);
  const nlohmann::json& rt = r["scenes"][0]["realtime"];

  const auto pid = rt["host"]["pid"].get<pid_t>();
  EXPECT_GT(pid, 0);
  EXPECT_FALSE(host_alive(pid)) << "gauss-eval left its gauss-host (pid " << pid << ") running";
  EXPECT_EQ(rt["host"]["exit_status"].get<int>(), 0) << read_text(rt["host"]["log"].get<std::string>());
  EXPECT_GT(rt["host"]["port"].get<int>(), 0);

  auto expect_exact = [](const nlohmann::json& sent, std::uint64_t budget, const std::string& where) {
    EXPECT_EQ(sent["differing_pixels"].get<std::uint64_t>(), 0u) << where;
    EXPECT_TRUE(sent["published_equals_sent"].get<bool>()) << where;
    EXPECT_TRUE(sent["sent_matches_scene"].get<bool>()) << where;
    EXPECT_EQ(sent["sent_gaussians"].get<std::uint64_t>(), budget) << where << ": the room holds more than M";
  };
  const auto& cameras = rt["fidelity"]["cameras"];
  ASSERT_EQ(cameras.size(), 1u);
  for (const auto& c : cameras) {
    EXPECT_TRUE(c["settle"]["converged"].get<bool>()) << c["settle"].dump();
    EXPECT_GT(c["settle"]["frames"].get<std::uint64_t>(), 0u);
    EXPECT_EQ(c["resident"].get<std::uint64_t>(), 2000u);
    EXPECT_TRUE(c["gt_hs"]["psnr_db"].is_number()) << c["gt_hs"].dump();
    EXPECT_TRUE(c["pc_hs"]["psnr_db"].is_number()) << c["pc_hs"].dump();
    EXPECT_GT(c["coverage"]["both"].get<double>(), 0.5);
    expect_exact(c["hs_vs_sent"], 2000, "fidelity camera");
  }
  const auto& teleport = rt["teleport"];
  ASSERT_EQ(teleport.size(), 2u);
  for (const auto& t : teleport) {
    const std::string mode = t["mode"].get<std::string>();
    for (const char* leg : {"first", "teleport", "return"})
      EXPECT_TRUE(t[leg]["converged"].get<bool>()) << mode << " " << leg << ": " << t[leg].dump();
    EXPECT_GT(t["return"]["slot_writes"].get<std::uint64_t>(), 0u) << mode << ": the return to A publishes edits";
    expect_exact(t["hs_vs_sent"], 2000, "teleport " + mode);
    // The flicker window at A: frames were compared, and a window that published nothing
    // rendered the settled view identically every frame.
    const auto& f = t["flicker"];
    EXPECT_GE(f["frames"].get<std::uint64_t>(), 2u) << mode << ": " << f.dump();
    EXPECT_GE(f["mean_abs_change"].get<double>(), 0.0) << mode;
    EXPECT_LE(f["mean_abs_change"].get<double>(), f["max_abs_change"].get<double>()) << mode;
    if (f["slot_writes"].get<std::uint64_t>() == 0) {
      EXPECT_EQ(f["max_abs_change"].get<double>(), 0.0) << mode;
    }
  }
  // Each query at its own M = |G_obj|: the target holds exactly min(|G_obj|, floor(rho M)),
  // recomputed here from the report's own figures.
  const auto& semantic = rt["semantic"];
  ASSERT_EQ(semantic.size(), 2u);
  for (const auto& q : semantic) {
    ASSERT_FALSE(q.contains("error")) << q.dump();
    const auto m = q["budget"].get<std::uint64_t>();
    const auto g_obj = q["object_gaussians"].get<std::uint64_t>();
    const auto reserve = static_cast<std::uint64_t>(std::floor(q["rho"].get<double>() * static_cast<double>(m)));
    const auto expected = std::min<std::uint64_t>(g_obj, reserve);
    EXPECT_GT(expected, 0u);
    EXPECT_EQ(q["resident_on_object"].get<std::uint64_t>(), expected) << q["query"];
    EXPECT_EQ(q["client_reported_object_gaussians"].get<std::uint64_t>(), g_obj) << q["query"];
    EXPECT_TRUE(q["settle"]["converged"].get<bool>()) << q["query"];
    EXPECT_GT(q["object_pixels"].get<std::uint64_t>(), 0u) << q["query"];
    expect_exact(q["hs_vs_sent"], m, "query " + q["query"].get<std::string>());
    // Settled without the query first: the budget was spread over the room, so the query
    // moved more of it onto the target, and each stage came after the one it needs.
    EXPECT_TRUE(q["settle_without_query"]["converged"].get<bool>()) << q["query"];
    EXPECT_LT(q["without_query"]["resident_on_object"].get<std::uint64_t>(), expected) << q["query"];
    const auto& l = q["latency"];
    for (const char* stage : {"targets_s", "highlight_s", "first_additional_s", "converged_s"})
      ASSERT_TRUE(l[stage].is_number()) << stage << " of " << q.dump();
    EXPECT_GT(l["targets_s"].get<double>(), 0.0);
    EXPECT_GE(l["highlight_s"].get<double>(), l["targets_s"].get<double>());
    EXPECT_GE(l["first_additional_s"].get<double>(), l["targets_s"].get<double>());
    EXPECT_GE(l["converged_s"].get<double>(), l["first_additional_s"].get<double>());
    EXPECT_EQ(l["initial_residency"].get<std::uint64_t>(), q["without_query"]["resident_on_object"].get<std::uint64_t>())
        << "the query took effect on the settled set";
  }
  for (const char* check : {"hs_equals_sent_render", "published_equals_sent", "sent_matches_scene",
                            "semantic_shares_match", "all_converged"})
    EXPECT_TRUE(r["checks"][check].get<bool>()) << check;
  EXPECT_NE(read_text(out / "report.md").find("wall-clock"), std::string::npos);
}

TEST(GaussEvalRealtime, RefusesNoTimingAndNamesAMissingHost) {
  const fs::path out = fs::path(GAUSS_TEST_OUTPUT_DIR) / "eval_app_gauss_eval_realtime_refusals";
  std::vector<std::string> contradiction = realtime_args(out);
  contradiction.push_back("--no-timing");
  EXPECT_EQ(run_eval(out, contradiction, 60s), 2);
  EXPECT_NE(read_text(out / "eval.log").find("--realtime contradicts --no-timing"), std::string::npos)
      << read_text(out / "eval.log");

  std::vector<std::string> no_host = realtime_args(out);
  no_host.insert(no_host.end(), {"--host-exe", (out / "no-such-gauss-host").string()});
  EXPECT_EQ(run_eval(out, no_host, 120s), 1);
  EXPECT_NE(read_text(out / "eval.log").find("no gauss-host executable at"), std::string::npos)
      << read_text(out / "eval.log");
  EXPECT_FALSE(fs::exists(out / "report.json")) << "an error writes no report";
}

}  // namespace
