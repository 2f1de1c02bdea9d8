// gauss-eval on a small configuration, twice: the deterministic report (--no-timing) must
// reproduce byte for byte; every client frame it measured must equal the host's render of
// the very set it sent (0 differing pixels); and every semantic query must hold exactly
// min(|G_obj|, floor(rho M)) of the client's M slots, recomputed here from the report's
// own figures. And a scene file (a room written as PLY + objects JSON here): no ground
// truth, so the GT-referenced figures are null, while everything else holds as for a room.
// And one run with the wall-clock figures: their phases are there and sane.
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
#include "gauss/engine/ply_gaussian.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/synthetic_scene.h"

namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

using gauss::test::read_text;

// One room, one fidelity camera, a small scene and view, a short flicker window, a
// two-point ablation: about 10-15 s a run on lavapipe (2 cores).
std::vector<std::string> eval_args(const fs::path& out) {
  return {GAUSS_EVAL_EXE, "--scenes", "0", "--gaussians", "12000", "--budget", "3000", "--size", "128x96",
          "--cameras", "1", "--quiet", "0.25", "--flicker-window", "0.3", "--ablation", "1000,6000", "--stereo-budget",
          "3000", "--no-timing",
          "--name", "ctest", "--out", out.string()};
}

void run_eval(const fs::path& out, const std::vector<std::string>& args) {
  fs::remove_all(out);
  fs::create_directories(out);
  gauss::test::ChildProcess eval;
  ASSERT_TRUE(eval.start(args, out / "eval.log"));
  const auto rc = eval.wait(240s);
  if (!rc) eval.stop(SIGKILL);
  ASSERT_EQ(rc.value_or(-1), 0) << read_text(out / "eval.log");
}

TEST(GaussEval, ReportReproducesAndItsExactnessChecksHold) {
  const fs::path base = fs::path(GAUSS_TEST_OUTPUT_DIR) / "eval_app_gauss_eval";
  ASSERT_NO_FATAL_FAILURE(run_eval(base / "a", eval_args(base / "a")));
  ASSERT_NO_FATAL_FAILURE(run_eval(base / "b", eval_args(base / "b")));
  const std::string a = read_text(base / "a" / "report.json"), b = read_text(base / "b" / "report.json");
  ASSERT_FALSE(a.empty());
  EXPECT_EQ(a, b) << "report.json differs between two runs of the same command";
  EXPECT_TRUE(fs::exists(base / "a" / "report.md"));
  EXPECT_TRUE(fs::exists(base / "a" / "room0_cam0.png"));

  const nlohmann::json r = nlohmann::json::parse(a);
  EXPECT_FALSE(r.contains("timing")) << "--no-timing leaves the wall-clock figures out";
  EXPECT_EQ(r["validation_errors"].get<std::uint64_t>(), 0u);
  ASSERT_EQ(r["scenes"].size(), 1u);
  const nlohmann::json& scene = r["scenes"][0];

  // HS equals the host's render of the sent set, at every view measured.
  std::size_t views = 0;
  for (const auto& c : scene["fidelity"]["cameras"]) {
    EXPECT_EQ(c["hs_vs_sent"]["differing_pixels"].get<std::uint64_t>(), 0u) << "fidelity camera " << c["camera"];
    EXPECT_TRUE(c["settle"]["converged"].get<bool>());
    EXPECT_TRUE(c["pc_hs"]["psnr_db"].is_number()) << c["pc_hs"].dump();
    EXPECT_GT(c["coverage"]["both"].get<double>(), 0.5);
    // --lod both (the default): the same camera without LoD, beside. At M = N/4 the leaves
    // alone leave holes the LoD cut covers, and its records are part of the M.
    ASSERT_TRUE(c.contains("without_lod")) << c.dump();
    const auto& w = c["without_lod"];
    EXPECT_EQ(w["hs_vs_sent"]["differing_pixels"].get<std::uint64_t>(), 0u);
    EXPECT_GT(c["coverage"]["hs"].get<double>(), w["coverage"]["hs"].get<double>());
    EXPECT_GT(c["pc_hs_all"]["psnr_db"].get<double>(), w["pc_hs_all"]["psnr_db"].get<double>());
    EXPECT_GT(c["lod_interior"].get<std::uint64_t>(), 0u);
    EXPECT_LE(c["resident"].get<std::uint64_t>(), 3000u);
    ++views;
  }
  EXPECT_EQ(views, 1u);

  // The semantic table: both queries, share = min(|G_obj|, floor(rho M)) / M exactly.
  ASSERT_EQ(scene["semantic"].size(), 2u);
  for (const auto& q : scene["semantic"]) {
    ASSERT_FALSE(q.contains("error")) << q.dump();
    const auto m = q["budget"].get<std::uint64_t>();
    const auto g_obj = q["object_gaussians"].get<std::uint64_t>();
    const double rho = q["rho"].get<double>();
    const std::uint64_t expected = std::min<std::uint64_t>(g_obj, static_cast<std::uint64_t>(std::floor(rho * m)));
    EXPECT_GT(g_obj, 0u);
    for (const char* view : {"near", "far"}) {
      const auto& with = q["views"][view]["with_query"];
      const auto& without = q["views"][view]["without_query"];
      EXPECT_EQ(with["resident_on_object"].get<std::uint64_t>(), expected) << q["query"] << " " << view;
      EXPECT_DOUBLE_EQ(with["share"].get<double>(), double(expected) / double(m));
      EXPECT_EQ(with["client_reported_object_gaussians"].get<std::uint64_t>(), g_obj);
      EXPECT_EQ(with["resident"].get<std::uint64_t>(), m) << "the query moves the budget, it does not grow it";
      EXPECT_LT(without["resident_on_object"].get<std::uint64_t>(), expected)
          << "without the query the target holds less (" << q["query"] << ", " << view << ")";
      EXPECT_EQ(with["hs_vs_sent_differing"].get<std::uint64_t>(), 0u);
      EXPECT_EQ(without["hs_vs_sent_differing"].get<std::uint64_t>(), 0u);
      EXPECT_GT(q["views"][view]["object_pixels"].get<std::uint64_t>(), 0u);
    }
    // The client's own stage events: resolved, then more target content, then converged.
    const auto& lat = q["latency"];
    ASSERT_TRUE(lat["first_additional_s"].is_number()) << lat.dump();
    EXPECT_LE(lat["resolved_s"].get<double>(), lat["first_additional_s"].get<double>()) << lat.dump();
    EXPECT_LE(lat["first_additional_s"].get<double>(), lat["converged_s"].get<double>()) << lat.dump();
  }
  // Teleport and return per publication mode; the budget ablation's points.
  ASSERT_EQ(scene["temporal"].size(), 2u);
  for (const auto& t : scene["temporal"]) {
    EXPECT_TRUE(t["return"]["converged"].get<bool>()) << t["mode"];
    EXPECT_TRUE(t["ssim_convergence_s"].is_number()) << t["mode"];
    EXPECT_GT(t["return"]["slot_writes"].get<std::uint64_t>(), 0u) << "the return to A publishes edits";
    EXPECT_GT(t["flicker"]["frames"].get<std::uint64_t>(), 0u);
  }
  // Two budgets, each with the LoD cut and without (--lod both).
  ASSERT_EQ(scene["ablation"].size(), 4u);
  std::size_t with_lod = 0;
  for (const auto& p : scene["ablation"]) {
    with_lod += p["lod"].get<bool>();
    for (const auto& c : p["cameras"]) EXPECT_EQ(c["hs_vs_sent_differing"].get<std::uint64_t>(), 0u);
  }
  EXPECT_EQ(with_lod, 2u);
  EXPECT_FALSE(r.contains("ablation")) << "the plot script's list carries frame times: only with timing";
  // Stage latencies: every live epoch reached the screen, after it became available.
  const auto& live = scene["model_latency"]["epochs"];
  ASSERT_FALSE(live.empty());
  for (const auto& e : live) {
    ASSERT_TRUE(e["visible_s"].is_number()) << e.dump();
    EXPECT_GE(e["sent_s"].get<double>(), 0.0) << e.dump();
    EXPECT_GE(e["visible_s"].get<double>(), e["sent_s"].get<double>()) << e.dump();
  }

  // Stereo frame timing: a far teleport streamed in at M and converged; the counts are
  // deterministic, the times are left out with --no-timing.
  const auto& stereo = scene["stereo_timing"];
  EXPECT_EQ(stereo["views"].get<int>(), 2);
  EXPECT_EQ(stereo["resident_at_a"].get<std::uint64_t>(), 3000u);
  EXPECT_EQ(stereo["resident_at_b"].get<std::uint64_t>(), 3000u);
  EXPECT_TRUE(stereo["teleport"]["converged"].get<bool>());
  EXPECT_GT(stereo["teleport"]["slot_writes"].get<std::uint64_t>(), 0u);

  EXPECT_TRUE(r["checks"]["hs_equals_sent_render"].get<bool>());
  EXPECT_TRUE(r["checks"]["semantic_shares_match"].get<bool>());
  EXPECT_TRUE(r["checks"]["all_converged"].get<bool>());
}

// Writes room 1 (its appearance Gaussians with their object ids) as a PLY and its object
// table as JSON: a scene file a user could have.
// Room 1 as a small scene of 4 epochs (8000 Gaussians).
gauss::Expected<gauss::SyntheticScene> small_room1() {
  gauss::SyntheticSceneConfig sc;
  sc.variant = 1;
  sc.target_gaussians = 8000;
  sc.epochs = 4;
  return gauss::SyntheticScene::create(sc);
}

// The store's appearance Gaussians (carriers left out), as a scene file holds them.
gauss::GaussianCloud appearance_cloud(const gauss::SceneStore& store) {
  gauss::GaussianCloud cloud;
  cloud.sh_degree = store.sh_degree();
  for (const gauss::Gaussian& g : store.gaussians())
    if (!g.carrier) cloud.gaussians.push_back(g);
  return cloud;
}

// The store's object table as an objects JSON.
void write_objects_json(const gauss::SceneStore& store, const fs::path& objects) {
  nlohmann::json table = nlohmann::json::array();
  for (const gauss::SemanticObject& o : store.objects())
    table.push_back({{"id", gauss::to_underlying(o.id)}, {"label", o.label}});
  std::ofstream(objects) << nlohmann::json{{"objects", table}}.dump();
}

// Whether every number in `j` is finite and not negative (the timing figures: times, counts).
// A null counts as not finite: the report's JSON writes a NaN or an infinity as null.
bool all_finite_and_non_negative(const nlohmann::json& j, std::string& where) {
  if (j.is_null()) return false;
  if (j.is_number()) return std::isfinite(j.get<double>()) && j.get<double>() >= 0.0;
  if (j.is_object() || j.is_array()) {
    for (auto it = j.begin(); it != j.end(); ++it)
      if (!all_finite_and_non_negative(*it, where)) {
        where = (j.is_object() ? it.key() : std::string("[]")) + (where.empty() ? "" : "." + where);
        return false;
      }
  }
  return true;
}

// The wall-clock half of the report, which the other runs leave out (--no-timing): the
// stereo frame timing's four phases (paced idle, streaming, idle again, then sustained
// frames back to back) each measured, and every figure a finite, non-negative number. Only
// that the figures are there and sane is checked, never what they are (timing decides no test).
TEST(GaussEval, WithTimingTheStereoPhasesAreEachMeasured) {
  const fs::path out = fs::path(GAUSS_TEST_OUTPUT_DIR) / "eval_app_gauss_eval_timing";
  ASSERT_NO_FATAL_FAILURE(run_eval(out, {GAUSS_EVAL_EXE, "--scenes", "0", "--gaussians", "12000", "--budget", "3000",
                                         "--size", "128x96", "--cameras", "1", "--quiet", "0.25", "--lod", "on",
                                         "--no-semantic", "--no-temporal", "--no-latency", "--stereo-budget", "3000",
                                         "--name", "ctest-timing", "--out", out.string()}));
  const nlohmann::json r = nlohmann::json::parse(read_text(out / "report.json"));
  EXPECT_EQ(r["validation_errors"].get<std::uint64_t>(), 0u);
  ASSERT_TRUE(r.contains("timing")) << "without --no-timing the report has its timing section";
  std::string where;
  EXPECT_TRUE(all_finite_and_non_negative(r["timing"], where)) << "timing." << where;
  const nlohmann::json& stereo = r["timing"]["scenes"][0]["stereo_timing"];
  ASSERT_TRUE(stereo.is_object()) << r["timing"].dump(1);
  EXPECT_EQ(stereo["views"].get<int>(), 2);
  for (const char* phase : {"idle_before", "streaming", "idle_after", "sustained"}) {
    SCOPED_TRACE(phase);
    const nlohmann::json& p = stereo["phases"][phase];
    ASSERT_TRUE(p.is_object()) << stereo.dump(1);
    const auto frames = p["frame_gpu_ms"]["n"].get<std::uint64_t>();
    EXPECT_GT(p["frame_cpu_ms"]["n"].get<std::uint64_t>(), 0u);
    EXPECT_GT(frames, 0u);
    EXPECT_EQ(p["visible_per_eye"]["n"].get<std::uint64_t>(), 2 * frames) << "one figure per eye and frame";
    EXPECT_GT(p["frame_gpu_ms"]["p50"].get<double>(), 0.0);
  }
  // The sustained frames render the set the stream left: every slot of the budget.
  EXPECT_EQ(stereo["phases"]["sustained"]["high_water"]["p50"].get<double>(), 3000.0);
  EXPECT_NE(read_text(out / "report.md").find("sustained"), std::string::npos);
}

void write_room_file(const fs::path& ply, const fs::path& objects) {
  auto scene = small_room1();
  ASSERT_TRUE(scene.ok()) << scene.message();
  gauss::SceneStore store;
  while (!scene->finished()) ASSERT_TRUE(scene->produce(store).ok());
  ASSERT_TRUE(gauss::write_gaussian_ply(ply, appearance_cloud(store), {.write_object_id = true}).ok());
  write_objects_json(store, objects);
}

TEST(GaussEval, ASceneFileHasNoGroundTruthAndKeepsEveryOtherCheck) {
  const fs::path base = fs::path(GAUSS_TEST_OUTPUT_DIR) / "eval_app_gauss_eval_file";
  fs::remove_all(base);
  fs::create_directories(base);
  ASSERT_NO_FATAL_FAILURE(write_room_file(base / "room1.ply", base / "room1_objects.json"));
  const fs::path out = base / "report";
  // A room is y up; a scene file's default would be the 3DGS -y.
  ASSERT_NO_FATAL_FAILURE(run_eval(out, {GAUSS_EVAL_EXE, "--scene", (base / "room1.ply").string(), "--up", "+y",
                                         "--objects", (base / "room1_objects.json").string(), "--budget", "2000", "--size", "96x72",
                                         "--cameras", "2", "--quiet", "0.25", "--flicker-window", "0.3",
                                         "--class-query", "chair", "--no-timing", "--name", "ctest-file", "--out",
                                         out.string()}));
  const nlohmann::json r = nlohmann::json::parse(read_text(out / "report.json"));
  ASSERT_EQ(r["scenes"].size(), 1u) << "--scene alone evaluates no room";
  const nlohmann::json& scene = r["scenes"][0];
  EXPECT_EQ(scene["name"], "room1.ply");
  EXPECT_EQ(scene["up"]["axis"], "+y");
  EXPECT_EQ(scene["up"]["from"], "--up +y");
  EXPECT_NE(r["command"].get<std::string>().find("--up +y"), std::string::npos) << r["command"];
  EXPECT_FALSE(scene["ground_truth"].get<bool>());
  ASSERT_EQ(scene["fidelity"]["cameras"].size(), 2u);
  for (const auto& c : scene["fidelity"]["cameras"]) {
    EXPECT_TRUE(c["gt_pc"].is_null()) << "no ground truth, no GT-PC: " << c["gt_pc"].dump();
    EXPECT_TRUE(c["gt_hs"].is_null());
    EXPECT_TRUE(c["pc_hs"]["psnr_db"].is_number()) << c["pc_hs"].dump();
    EXPECT_GT(c["coverage"]["both"].get<double>(), 0.2) << "the orbit camera sees the scene";
    EXPECT_EQ(c["hs_vs_sent"]["differing_pixels"].get<std::uint64_t>(), 0u);
  }
  ASSERT_EQ(scene["semantic"].size(), 2u);
  for (const auto& q : scene["semantic"]) {
    ASSERT_FALSE(q.contains("error")) << q.dump();
    const auto m = q["budget"].get<std::uint64_t>();
    const std::uint64_t expected = std::min<std::uint64_t>(
        q["object_gaussians"].get<std::uint64_t>(), static_cast<std::uint64_t>(std::floor(q["rho"].get<double>() * m)));
    for (const char* view : {"near", "far"}) {
      const auto& v = q["views"][view];
      EXPECT_EQ(v["with_query"]["resident_on_object"].get<std::uint64_t>(), expected) << q["query"] << " " << view;
      EXPECT_TRUE(v["gt_pc_object"].is_null());
      EXPECT_TRUE(v["with_query"]["pc_hs_object"]["psnr_db"].is_number()) << v.dump();
      EXPECT_GT(v["object_pixels"].get<std::uint64_t>(), 0u) << "the target's own render covers pixels";
      EXPECT_EQ(v["with_query"]["hs_vs_sent_differing"].get<std::uint64_t>(), 0u);
    }
  }
  EXPECT_FALSE(scene.contains("model_latency")) << "one epoch: no model edits to time";
  ASSERT_EQ(scene["temporal"].size(), 2u);
  for (const auto& t : scene["temporal"]) {
    EXPECT_TRUE(t["return"]["converged"].get<bool>()) << t["mode"];
    EXPECT_GT(t["teleport"]["slot_writes"].get<std::uint64_t>(), 0u) << "the close-up of the far side changes the set";
  }
  EXPECT_EQ(r["validation_errors"].get<std::uint64_t>(), 0u);
  EXPECT_TRUE(r["checks"]["hs_equals_sent_render"].get<bool>());
  EXPECT_TRUE(r["checks"]["all_converged"].get<bool>());
  const std::string md = read_text(out / "report.md");
  EXPECT_NE(md.find("| room1.ply | 0 | n/a |"), std::string::npos) << "the GT-PC column says n/a";
}

// A trainer's snapshot folder: room 1 after epochs 2, 3 and 4 (appearance Gaussians with
// their ids and object ids), snap_2.ply .. snap_4.ply, plus the object table.
void write_snapshot_folder(const fs::path& folder) {
  fs::create_directories(folder);
  auto scene = small_room1();
  ASSERT_TRUE(scene.ok()) << scene.message();
  gauss::SceneStore store;
  for (int e = 1; e <= 4; ++e) {
    ASSERT_TRUE(scene->produce(store).ok());
    if (e < 2) continue;
    ASSERT_TRUE(gauss::write_gaussian_ply(folder / ("snap_" + std::to_string(e) + ".ply"), appearance_cloud(store),
                                          {.write_object_id = true, .write_gaussian_id = true})
                    .ok());
  }
  write_objects_json(store, folder / "objects.json");
  // The trainer's cameras beside its snapshots (3DGS cameras.json: camera-to-world rotation
  // rows, OpenCV axes): three headings about the room's +y, image down -y, so the capture's
  // up is +y where the 3DGS default would be -y.
  std::string cams = "[";
  for (int k = 0; k < 3; ++k) {
    const double a = 0.7 * k, c = std::cos(a), s = std::sin(a);
    // Columns: right (-c, 0, s), down (0, -1, 0), forward (s, 0, c) = right x down.
    cams += std::string(k ? "," : "") + "{\"id\": " + std::to_string(k) + ", \"position\": [0, 1.5, 0], \"rotation\": [[" +
            std::to_string(-c) + ", 0, " + std::to_string(s) + "], [0, -1, 0], [" + std::to_string(s) + ", 0, " +
            std::to_string(c) + "]]}";
  }
  std::ofstream(folder / "cameras.json") << cams << "]";
}

TEST(GaussEval, ASnapshotFolderIsEvaluatedAtItsLastSnapshotAndReplayedForTheEditLatencies) {
  const fs::path base = fs::path(GAUSS_TEST_OUTPUT_DIR) / "eval_app_gauss_eval_folder";
  fs::remove_all(base);
  ASSERT_NO_FATAL_FAILURE(write_snapshot_folder(base / "snapshots"));
  const fs::path out = base / "report";
  ASSERT_NO_FATAL_FAILURE(run_eval(out, {GAUSS_EVAL_EXE, "--scene", (base / "snapshots").string(), "--budget", "2000",
                                         "--size", "96x72", "--cameras", "1", "--quiet", "0.25", "--no-semantic",
                                         "--no-temporal", "--epoch-period", "0.2", "--no-timing", "--name",
                                         "ctest-folder", "--out", out.string()}));
  const nlohmann::json r = nlohmann::json::parse(read_text(out / "report.json"));
  ASSERT_EQ(r["scenes"].size(), 1u);
  const nlohmann::json& scene = r["scenes"][0];
  EXPECT_EQ(scene["name"], "snapshots");
  EXPECT_EQ(scene["up"]["axis"], "+y") << "the trainer's cameras.json in the folder decides the up: " << scene["up"];
  EXPECT_NE(scene["up"]["from"].get<std::string>().find("cameras.json (3 capture cameras)"), std::string::npos)
      << scene["up"];
  EXPECT_EQ(r["command"].get<std::string>().find("--up"), std::string::npos) << "no --up given, none written";
  EXPECT_EQ(scene["snapshots"].get<int>(), 3);
  EXPECT_FALSE(scene["ground_truth"].get<bool>());
  EXPECT_GT(scene["objects"].get<std::uint64_t>(), 0u) << "objects.json in the folder names the objects";
  ASSERT_EQ(scene["fidelity"]["cameras"].size(), 1u);
  EXPECT_EQ(scene["fidelity"]["cameras"][0]["hs_vs_sent"]["differing_pixels"].get<std::uint64_t>(), 0u);
  // Three snapshots: the first before the client connects, the other two replayed live,
  // each sent, received, published and shown.
  ASSERT_TRUE(scene.contains("model_latency")) << scene.dump();
  const auto& epochs = scene["model_latency"]["epochs"];
  ASSERT_EQ(epochs.size(), 2u) << scene["model_latency"].dump();
  for (const auto& e : epochs) {
    EXPECT_GT(e["edits"].get<std::uint64_t>(), 0u) << e.dump();
    EXPECT_GE(e["visible_s"].get<double>(), e["published_s"].get<double>()) << e.dump();
  }
  EXPECT_TRUE(r["checks"]["hs_equals_sent_render"].get<bool>());
  EXPECT_EQ(r["validation_errors"].get<std::uint64_t>(), 0u);
}

}  // namespace
