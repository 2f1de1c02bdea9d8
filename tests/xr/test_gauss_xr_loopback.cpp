// gauss-xr end to end against the headless OpenXR runtime (tests/xr/headless_runtime, loaded
// by the real OpenXR loader through XR_RUNTIME_JSON) and a gauss-host over loopback ENet:
// a scripted session (a head pose held still, a trigger pull with the right controller
// aimed at an object, an exit) must show, in the projection layer the runtime read back,
// exactly the host's own render (gauss-render) of the set it sent, from the cameras
// gauss-xr made of the runtime's views; A sends the first class query, B clears it, the
// pull must query the object under the ray and that object must get min(|G_obj|,
// floor(rho M)) of the M slots. And the faults: a lost
// session ends gauss-xr cleanly with a message, no runtime and a runtime without
// XR_KHR_vulkan_enable2 are named.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "child_process.h"
#include "test_data.h"
#include "text_file.h"
#include "gauss/engine/camera_io.h"
#include "gauss/engine/image_io.h"
#include "gauss/engine/synthetic_scene.h"
#include "gauss/xr/xr_pose.h"

namespace {

using namespace std::chrono_literals;
using gauss::test::read_text;
using Json = nlohmann::json;
namespace fs = std::filesystem;

constexpr std::uint32_t kBudget = 3000;
constexpr double kRho = 0.5;
constexpr int kExitFrame = 600;
constexpr int kPullFrame = 150;

Json pose_json(const gauss::xr::XrPose& p) {
  return Json{{"position", {p.position.x, p.position.y, p.position.z}},
              {"orientation", {p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z}}};
}

// The scene the host serves (same seed, size and epochs), for the aim's ground truth.
gauss::SyntheticScene room() {
  gauss::SyntheticSceneConfig sc;
  sc.variant = 0;
  sc.target_gaussians = 10000;
  sc.epochs = 4;
  auto s = gauss::SyntheticScene::create(sc);
  EXPECT_TRUE(s.ok()) << s.message();
  return std::move(*s);
}

struct Aim {
  gauss::xr::XrPose head, hand;
  gauss::ObjectId object{gauss::kNoObject};  // what the analytic scene shows along the aim
};

// Head and right hand at a point of the room looking at the robot arm; the hand's ray is the
// view's centre ray, and the ground truth's object there is what the pull must select.
Aim aim_at_robot_arm(const gauss::SyntheticScene& scene) {
  Aim a;
  const gauss::SyntheticObjectInfo* target = nullptr;  // the arm
  for (const auto& o : scene.objects())
    if (o.label == "robot_arm") target = &o;
  EXPECT_NE(target, nullptr);
  if (target == nullptr) return a;
  const glm::dvec3 centre = 0.5 * (glm::dvec3(target->extent_min) + glm::dvec3(target->extent_max));
  // 1.5 m towards the room's -z side and 0.8 m above the arm's middle: free space in room 0
  // (the table, nearer the room centre, would hold the controller inside its Gaussians).
  const glm::dvec3 eye = centre + glm::dvec3(0.3, 0.8, -1.5);
  // The head looks at the arm's box centre; the hand points through the pixel nearest the
  // view's centre where the analytic scene shows the arm (a thin arm's box centre is air).
  gauss::Camera view;
  view.width = view.height = 33;
  view.fx = view.fy = 30.0;
  view.cx = view.cy = 16.5;
  view.world_to_camera = glm::inverse(gauss::opencv_look_at(eye, centre, glm::dvec3(0, 1, 0)));
  const gauss::GroundTruthImage gt = scene.render_ground_truth(view);
  int best = -1;
  double best_d = 1e9;
  for (int y = 0; y < 33; ++y)
    for (int x = 0; x < 33; ++x)
      if (gt.object[std::size_t(y * 33 + x)] == target->id && std::hypot(x - 16, y - 16) < best_d) {
        best_d = std::hypot(x - 16, y - 16);
        best = y * 33 + x;
      }
  a.head = gauss::xr::pose_of_camera(view, glm::dmat4(1.0));
  if (best < 0) return a;
  a.object = target->id;
  const glm::dmat4 c2w = glm::inverse(view.world_to_camera);
  const glm::dvec3 ray = glm::dmat3(c2w) * glm::dvec3((best % 33 + 0.5 - view.cx) / view.fx,
                                                      (best / 33 + 0.5 - view.cy) / view.fy, 1.0);
  gauss::Camera hand = view;
  hand.world_to_camera = glm::inverse(gauss::opencv_look_at(eye, eye + ray, glm::dvec3(0, 1, 0)));
  a.hand = gauss::xr::pose_of_camera(hand, glm::dmat4(1.0));
  return a;
}

// No fused surface by default: the scene is final after its four epochs, so the client's last
// frame is of the final scene. `scene` replaces the synthetic room's options.
std::uint16_t start_host(gauss::test::ChildProcess& host, const fs::path& out,
                         const std::vector<std::string>& scene = {"--gaussians", "10000", "--epochs", "4",
                                                                  "--epoch-period", "0.05", "--surface-voxel", "0"}) {
  for (int attempt = 0; attempt < 3; ++attempt) {
    const std::uint16_t port = gauss::test::free_udp_port();
    if (port == 0) return 0;
    const std::string ep = "127.0.0.1:" + std::to_string(port);
    std::vector<std::string> args = {GAUSS_HOST_EXE, "--bind", ep};
    args.insert(args.end(), scene.begin(), scene.end());
    args.insert(args.end(), {"--duration", "400", "--dump-sent", (out / "dump").string(), "--quiet"});
    if (!host.start(args, out / "host.log")) return 0;
    if (!host.wait(700ms)) return port;  // still running: it bound the port
  }
  return 0;
}

// Runs gauss-xr with the runtime's script; returns its exit status (-1: timed out).
int run_xr(const fs::path& out, const Json& script, std::uint16_t port, const std::vector<std::string>& extra = {}) {
  std::ofstream(out / "script.json") << script.dump(2);
  fs::create_directories(out / "capture");
  ::setenv("GAUSS_XR_HEADLESS_SCRIPT", (out / "script.json").c_str(), 1);
  ::setenv("GAUSS_XR_HEADLESS_CAPTURE", (out / "capture").c_str(), 1);
  gauss::test::ChildProcess xr;
  std::vector<std::string> args = {GAUSS_XR_EXE, "--host", "127.0.0.1:" + std::to_string(port), "--budget",
                                   std::to_string(kBudget), "--rho", "0.5", "--no-highlight", "--out", (out / "xr").string()};
  args.insert(args.end(), extra.begin(), extra.end());
  EXPECT_TRUE(xr.start(args, out / "xr.log"));
  const auto rc = xr.wait(300s);
  if (!rc) xr.stop(SIGKILL);
  ::unsetenv("GAUSS_XR_HEADLESS_SCRIPT");
  ::unsetenv("GAUSS_XR_HEADLESS_CAPTURE");
  // CTest turns Vulkan validation on (GAUSS_VALIDATION=1), and the child inherits it.
  EXPECT_EQ(read_text(out / "xr.log").find("validation ERROR"), std::string::npos) << read_text(out / "xr.log");
  return rc.value_or(-1);
}

std::vector<std::uint8_t> read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), {});
}

TEST(GaussXrLoopback, TheHeadsetShowsTheHostsRenderOfTheSentSetAndThePullQueriesTheObject) {
  const fs::path out = fs::path(GAUSS_TEST_OUTPUT_DIR) / "xr_gauss_xr_loopback";
  fs::remove_all(out);
  fs::create_directories(out);
  const gauss::SyntheticScene scene = room();
  const Aim aim = aim_at_robot_arm(scene);
  ASSERT_NE(aim.object, gauss::kNoObject) << "the aim must hit the robot arm in the analytic scene";

  gauss::test::ChildProcess host;
  const std::uint16_t port = start_host(host, out);
  ASSERT_NE(port, 0) << read_text(out / "host.log");

  Json capture = Json::array();
  for (int f = kExitFrame - 40; f <= kExitFrame + 2; ++f) capture.push_back(f);
  const Json script{
      {"width", 160},
      {"height", 120},
      {"ipd", 0.064},
      {"fov", {{"left", -0.75}, {"right", 0.7}, {"up", 0.6}, {"down", -0.62}}},
      // A (the first class query), B (cleared), then the pull, so the pull's query is the one
      // active at the end.
      {"keyframes",
       {{{"frame", 0}, {"head", pose_json(aim.head)}, {"right", {{"aim", pose_json(aim.hand)}, {"trigger", 0.0}}}},
        {{"frame", kPullFrame - 60}, {"right", {{"a", true}}}},
        {{"frame", kPullFrame - 55}, {"right", {{"a", false}}}},
        {{"frame", kPullFrame - 40}, {"right", {{"thumbstick", {0.0, -1.0}}}}},  // rho down a step: re-sent
        {{"frame", kPullFrame - 35}, {"right", {{"thumbstick", {0.0, 0.0}}}}},
        {{"frame", kPullFrame - 30}, {"right", {{"b", true}}}},
        {{"frame", kPullFrame - 25}, {"right", {{"b", false}}}},
        {{"frame", kPullFrame}, {"right", {{"trigger", 1.0}}}},
        {{"frame", kPullFrame + 5}, {"right", {{"trigger", 0.0}}}}}},
      {"events", {{{"frame", kExitFrame}, {"type", "exit"}}}},
      {"capture", capture}};
  ASSERT_EQ(run_xr(out, script, port), 0) << read_text(out / "xr.log");

  // The host writes the set it sent when the client leaves; then it is stopped.
  const fs::path dump = out / "dump" / "gauss-xr.ply";
  for (int i = 0; i < 200 && !fs::exists(dump); ++i) std::this_thread::sleep_for(50ms);
  EXPECT_EQ(host.stop(SIGINT).value_or(-1), 0) << read_text(out / "host.log");
  ASSERT_TRUE(fs::exists(dump)) << read_text(out / "host.log");

  const Json summary = Json::parse(read_text(out / "xr" / "summary.json"));
  // The session went through its states and ended by the runtime's exit.
  const std::vector<std::string> phases = summary["phases"];
  EXPECT_EQ(phases.back(), "exiting");
  EXPECT_NE(std::find(phases.begin(), phases.end(), "running"), phases.end());
  const std::vector<std::string> states = summary["session_states"];
  const std::vector<std::string> lifecycle{"IDLE",    "READY",        "SYNCHRONIZED", "VISIBLE", "FOCUSED",
                                           "VISIBLE", "SYNCHRONIZED", "STOPPING",     "IDLE",    "EXITING"};
  EXPECT_EQ(states, lifecycle) << summary["session_states"].dump();
  // The synthetic room is y up, as the headset's room: the host said so, and nothing turned.
  EXPECT_EQ(summary["scene_up"], (Json{{"up", {0.0, 1.0, 0.0}},
                                       {"from", "announced by the host"},
                                       {"facing_subject", false},
                                       {"origin_height", 0.0}}))
      << summary.dump(2);
  // The pull queried the object under the ray, and it got its share of the budget.
  const Json& queries = summary["queries"];
  ASSERT_EQ(queries.size(), 4u) << summary.dump(2);
  EXPECT_EQ(queries[0]["kind"], "class") << queries.dump();
  EXPECT_EQ(queries[0]["text"], "chair") << "A cycles the class labels in order: 'chair' is the first of room 0's";
  EXPECT_DOUBLE_EQ(queries[0]["rho"].get<double>(), kRho);
  EXPECT_EQ(queries[1]["kind"], "rho") << "the thumbstick re-sends the active query";
  EXPECT_DOUBLE_EQ(queries[1]["rho"].get<double>(), kRho - 0.05);
  EXPECT_EQ(queries[2]["kind"], "clear") << queries.dump();
  EXPECT_EQ(queries[3]["kind"], "instance") << queries.dump();
  EXPECT_EQ(queries[3]["object"].get<std::int64_t>(), gauss::to_underlying(aim.object)) << queries.dump();
  EXPECT_DOUBLE_EQ(queries[3]["rho"].get<double>(), kRho - 0.05) << "the pull keeps the stepped rho";
  const Json& q = summary["query"];
  ASSERT_TRUE(q["active"].get<bool>()) << summary.dump(2);
  const auto expected = std::min<std::uint64_t>(q["target_members"].get<std::uint64_t>(),
                                                static_cast<std::uint64_t>(std::floor((kRho - 0.05) * kBudget)));
  EXPECT_GT(expected, 0u);
  EXPECT_EQ(q["target_resident"].get<std::uint64_t>(), expected) << summary.dump(2);

  // The last frame gauss-xr showed, as the runtime read it back: find it by display time.
  const std::int64_t shown_time = summary["last_display_time"].get<std::int64_t>();
  fs::path frame_json;
  for (const auto& e : fs::directory_iterator(out / "capture"))
    if (e.path().extension() == ".json" && e.path().filename().string().rfind("frame-", 0) == 0) {
      const Json f = Json::parse(read_text(e.path()));
      if (f.contains("predicted_display_time") && f["predicted_display_time"].get<std::int64_t>() == shown_time)
        frame_json = e.path();
    }
  ASSERT_FALSE(frame_json.empty()) << "no captured frame has gauss-xr's last display time " << shown_time;
  const std::string stem = frame_json.stem().string();
  // The depth layer rides with each projection view: the renderer's depth as projected depth
  // for the eye cameras' planes (render::DepthProjection, unit-tested on its values).
  EXPECT_TRUE(summary["depth_layer"].get<bool>()) << "the runtime offers XR_KHR_composition_layer_depth";
  const Json shown_frame = Json::parse(read_text(frame_json));
  for (const Json& v : shown_frame["views"]) {
    ASSERT_TRUE(v.contains("depth")) << v.dump();
    EXPECT_EQ(v["depth"]["format"], "VK_FORMAT_D32_SFLOAT") << v.dump();
    EXPECT_FLOAT_EQ(v["depth"]["near_z"].get<float>(), 0.05f);
    EXPECT_FLOAT_EQ(v["depth"]["far_z"].get<float>(), 1000.0f);
  }
  for (int eye = 0; eye < 2; ++eye) {
    const fs::path cam = out / "xr" / ("eye" + std::to_string(eye) + ".camera.json");
    gauss::test::ChildProcess render;
    const fs::path png = out / ("host_eye" + std::to_string(eye) + ".png");
    ASSERT_TRUE(render.start({GAUSS_RENDER_EXE, "--scene", dump.string(), "--camera", cam.string(), "--order",
                              (out / "xr" / "final_slot_ids.json").string(), "--out", png.string()},
                             out / "render.log"));
    const auto rc = render.wait(120s);
    if (!rc) render.stop(SIGKILL);
    ASSERT_EQ(rc.value_or(-1), 0) << read_text(out / "render.log");
    auto host_img = gauss::read_png_rgba8(png);
    ASSERT_TRUE(host_img.ok()) << host_img.message();
    const std::vector<std::uint8_t> shown = read_bytes(out / "capture" / (stem + "-eye" + std::to_string(eye) + ".rgba"));
    ASSERT_EQ(shown.size(), host_img->pixels.size());
    std::size_t differ = 0, lit = 0;
    for (std::size_t i = 0; i + 3 < shown.size(); i += 4) {
      bool same = true;
      for (int c = 0; c < 4; ++c) same = same && shown[i + c] == host_img->pixels[i + c];
      differ += same ? 0 : 1;
      lit += shown[i] + shown[i + 1] + shown[i + 2] > 30 ? 1 : 0;
    }
    EXPECT_EQ(differ, 0u) << "eye " << eye << ": pixels differing between the headset's layer and the host's render";
    EXPECT_GT(lit, shown.size() / 16) << "eye " << eye << ": the scene is in view";
  }
}

// A 3DGS capture is y down: the host says so, and gauss-xr turns the scene so that its up is
// the room's. A level head then sees the scene's -y as image-up (its camera's down is the
// scene's +y); before, the capture stood on its head. In STAGE space (origin on the floor) the
// capture's origin is at the user's eye height (--eye-height, here a seated 1.25 m): the
// runtime's head, 1.6 m up, is 0.35 m above it.
TEST(GaussXrLoopback, ACaptureStandsUprightInTheRoom) {
  GAUSS_REQUIRE_DATA(scene, "splats/fruit_drops_sh3.v4.spz");
  const fs::path out = fs::path(GAUSS_TEST_OUTPUT_DIR) / "xr_gauss_xr_upright";
  fs::remove_all(out);
  fs::create_directories(out);
  gauss::test::ChildProcess host;
  const std::uint16_t port = start_host(host, out, {"--scene", scene.string()});
  ASSERT_NE(port, 0) << read_text(out / "host.log");
  // Frames come as fast as they render (a virtual clock): enough of them for the Welcome.
  const Json script{{"width", 32}, {"height", 24}, {"events", {{{"frame", 800}, {"type", "exit"}}}}, {"capture", Json::array()}};
  // A seated user's eye height: the headless runtime's head stands 1.6 m above the floor.
  ASSERT_EQ(run_xr(out, script, port, {"--stage", "--eye-height", "1.25"}), 0) << read_text(out / "xr.log");
  EXPECT_EQ(host.stop(SIGINT).value_or(-1), 0);
  const Json summary = Json::parse(read_text(out / "xr" / "summary.json"));
  EXPECT_EQ(summary["scene_up"], (Json{{"up", {0.0, -1.0, 0.0}},
                                       {"from", "announced by the host"},
                                       {"facing_subject", true},
                                       {"origin_height", 1.25}}))
      << summary.dump(2);
  EXPECT_NE(read_text(out / "xr.log").find("the scene's up is -y (announced by the host)"), std::string::npos)
      << read_text(out / "xr.log");
  auto cam = gauss::read_camera_json(out / "xr" / "eye0.camera.json");
  ASSERT_TRUE(cam.ok()) << cam.message();
  // The camera's +y (image down) in the scene: row 1 of world_to_camera's rotation.
  const glm::dvec3 down(cam->world_to_camera[0][1], cam->world_to_camera[1][1], cam->world_to_camera[2][1]);
  EXPECT_LT(glm::length(down - glm::dvec3(0.0, 1.0, 0.0)), 1e-9) << down.x << " " << down.y << " " << down.z;
  // And the subject (the label, 2 m from the origin) is ahead: the headset's last frame shows it.
  const glm::dvec3 ahead(cam->world_to_camera[0][2], cam->world_to_camera[1][2], cam->world_to_camera[2][2]);
  EXPECT_LT(ahead.z, -0.9) << "the subject lies toward the scene's -z from its origin";
  // The eye stands 1.6 - 1.25 m above the scene's origin (up is the scene's -y), half the IPD
  // aside.
  const glm::dvec3 eye(glm::inverse(cam->world_to_camera)[3]);
  EXPECT_LT(glm::length(eye - glm::dvec3(0.0, -0.35, 0.0)), 0.05) << eye.x << " " << eye.y << " " << eye.z;
}

TEST(GaussXrLoopback, ALostSessionEndsTheProgramWithAMessage) {
  const fs::path out = fs::path(GAUSS_TEST_OUTPUT_DIR) / "xr_gauss_xr_loss";
  fs::remove_all(out);
  fs::create_directories(out);
  gauss::test::ChildProcess host;
  const std::uint16_t port = start_host(host, out);
  ASSERT_NE(port, 0) << read_text(out / "host.log");
  const Json script{{"width", 64}, {"height", 48}, {"events", {{{"frame", 30}, {"type", "loss"}}}}, {"capture", Json::array()}};
  EXPECT_EQ(run_xr(out, script, port), 1);
  const std::string log = read_text(out / "xr.log");
  EXPECT_NE(log.find("session was lost"), std::string::npos) << log;
  const Json summary = Json::parse(read_text(out / "xr" / "summary.json"));
  const std::vector<std::string> phases = summary["phases"];
  EXPECT_EQ(phases.back(), "loss pending");
  EXPECT_GE(summary["frames_ended"].get<std::uint64_t>(), 25u);
  EXPECT_EQ(host.stop(SIGINT).value_or(-1), 0);
}

TEST(GaussXrLoopback, NoRuntimeARuntimeWithoutVulkanAndUnusableFormatsAreNamed) {
  const fs::path out = fs::path(GAUSS_TEST_OUTPUT_DIR) / "xr_gauss_xr_refusals";
  fs::remove_all(out);
  fs::create_directories(out);
  const std::string saved = std::getenv("XR_RUNTIME_JSON") ? std::getenv("XR_RUNTIME_JSON") : "";
  ::setenv("XR_RUNTIME_JSON", (out / "no-such-runtime.json").c_str(), 1);
  EXPECT_EQ(run_xr(out, Json::object(), 9), 1);
  EXPECT_NE(read_text(out / "xr.log").find("no OpenXR runtime"), std::string::npos) << read_text(out / "xr.log");
  // An eye height means nothing without the floor-origin space: refused before anything starts.
  EXPECT_NE(run_xr(out, Json::object(), 9, {"--eye-height", "1.2"}), 0);
  EXPECT_NE(read_text(out / "xr.log").find("--eye-height requires --stage"), std::string::npos) << read_text(out / "xr.log");
  ::setenv("XR_RUNTIME_JSON", saved.c_str(), 1);
  ::setenv("GAUSS_XR_HEADLESS_NO_VULKAN", "1", 1);
  EXPECT_EQ(run_xr(out, Json::object(), 9), 1);
  ::unsetenv("GAUSS_XR_HEADLESS_NO_VULKAN");
  EXPECT_NE(read_text(out / "xr.log").find("XR_KHR_vulkan_enable2"), std::string::npos) << read_text(out / "xr.log");
  // Only BGRA swapchains: the byte copy cannot swizzle, so gauss-xr says which formats it
  // needs and which were offered (VkFormat 44 = B8G8R8A8_UNORM).
  ::setenv("GAUSS_XR_HEADLESS_ONLY_BGRA", "1", 1);
  EXPECT_EQ(run_xr(out, Json::object(), 9), 1);
  ::unsetenv("GAUSS_XR_HEADLESS_ONLY_BGRA");
  const std::string log = read_text(out / "xr.log");
  EXPECT_NE(log.find("no swapchain format"), std::string::npos) << log;
  EXPECT_NE(log.find("offers 44"), std::string::npos) << log;
}

}  // namespace

namespace {

// Lines of `text` containing `needle`.
std::size_t count_lines_with(const std::string& text, const std::string& needle) {
  std::size_t n = 0;
  for (std::size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1)) ++n;
  return n;
}

// The host stops while the headset runs: the headset keeps drawing the published scene with
// the amber banner (a quad layer the runtime sees), reconnects to the host started again on
// the same port, and the banner goes; SIGINT then ends gauss-xr cleanly with its outputs.
TEST(GaussXrLoopback, TheHostGoingAwayShowsABannerUntilItIsBack) {
  const fs::path out = fs::path(GAUSS_TEST_OUTPUT_DIR) / "xr_gauss_xr_host_away";
  fs::remove_all(out);
  fs::create_directories(out);
  gauss::test::ChildProcess host;
  const std::uint16_t port = start_host(host, out);
  ASSERT_NE(port, 0) << read_text(out / "host.log");
  const Json script{{"width", 64}, {"height", 48}, {"capture", Json::array()}};
  std::ofstream(out / "script.json") << script.dump(2);
  fs::create_directories(out / "capture");
  ::setenv("GAUSS_XR_HEADLESS_SCRIPT", (out / "script.json").c_str(), 1);
  ::setenv("GAUSS_XR_HEADLESS_CAPTURE", (out / "capture").c_str(), 1);
  gauss::test::ChildProcess xr;
  ASSERT_TRUE(xr.start({GAUSS_XR_EXE, "--host", "127.0.0.1:" + std::to_string(port), "--budget", "2000", "--out",
                        (out / "xr").string()},
                       out / "xr.log"));
  ::unsetenv("GAUSS_XR_HEADLESS_SCRIPT");
  ::unsetenv("GAUSS_XR_HEADLESS_CAPTURE");
  const auto wait_for = [&](std::size_t connects, std::chrono::seconds limit) {
    const auto until = std::chrono::steady_clock::now() + limit;
    while (std::chrono::steady_clock::now() < until) {
      if (count_lines_with(read_text(out / "xr.log"), "connected to") >= connects) return true;
      std::this_thread::sleep_for(100ms);
    }
    return false;
  };
  ASSERT_TRUE(wait_for(1, 60s)) << read_text(out / "xr.log");
  std::this_thread::sleep_for(1s);  // the stream arrives and is drawn
  EXPECT_EQ(host.stop(SIGINT).value_or(-1), 0);
  std::this_thread::sleep_for(1s);  // frames without a host
  gauss::test::ChildProcess again;  // the same port: the client retries it
  ASSERT_TRUE(again.start({GAUSS_HOST_EXE, "--bind", "127.0.0.1:" + std::to_string(port), "--gaussians", "10000",
                           "--epochs", "4", "--epoch-period", "0.05", "--surface-voxel", "0", "--duration", "400",
                           "--quiet"},
                          out / "host2.log"));
  const bool back = wait_for(2, 60s);
  std::this_thread::sleep_for(1s);  // frames after the reconnect
  EXPECT_EQ(xr.stop(SIGINT).value_or(-1), 0) << read_text(out / "xr.log");
  EXPECT_EQ(again.stop(SIGINT).value_or(-1), 0);
  ASSERT_TRUE(back) << "gauss-xr did not reconnect:\n" << read_text(out / "xr.log");
  EXPECT_EQ(read_text(out / "xr.log").find("validation ERROR"), std::string::npos) << read_text(out / "xr.log");

  const Json summary = Json::parse(read_text(out / "xr" / "summary.json"));
  EXPECT_GE(summary["connection"]["disconnects"].get<std::uint64_t>(), 1u) << summary.dump(2);
  EXPECT_GE(summary["connection"]["welcomes"].get<std::uint64_t>(), 2u) << summary.dump(2);
  EXPECT_GT(summary["banner_frames"].get<std::uint64_t>(), 0u) << summary.dump(2);
  EXPECT_GT(summary["resident"].get<std::uint64_t>(), 0u) << "the scene stayed and came back";
  const Json session = Json::parse(read_text(out / "capture" / "session.json"));
  const std::vector<std::uint64_t> quads = session["quad_frames"];
  ASSERT_FALSE(quads.empty()) << "the runtime saw no banner";
  const std::uint64_t frames = session["frame_count"].get<std::uint64_t>();
  EXPECT_LT(quads.back() + 10, frames) << "the banner must be gone once the host is back";
  EXPECT_LT(quads.size(), frames) << "not every frame had the banner";
}

}  // namespace
