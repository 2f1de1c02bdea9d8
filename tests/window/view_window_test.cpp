// view_window_test: gauss-view's windowed mode end to end, on a real window (Xvfb in CI:
// xvfb-run -a -s "-screen 0 1280x800x24" view_window_test GAUSS_VIEW OUT_DIR [GAUSS_HOST]).
//
// Writes a 2000-Gaussian scene (a coloured wall 3 m in front of the camera) and a camera
// JSON, then runs gauss-view windowed on it (640x480, 12 frames, a screenshot of frame 9):
//   ui      the panels on (the default);
//   noui    --no-ui: the scene alone;
//   ui_large, noui_large  the same at 1040x640;
//   stereo  --no-ui --stereo 0.2: two eyes side by side.
// Checks: every run exits 0 with no validation error line on stderr; the scene shows
// (the no-UI shot is mostly not background); at 640x480 the panels start collapsed (the
// connection panel's title bar differs from the no-UI shot, the left column below the
// title bars does not); at 1040x640 they start expanded (the UI shot differs over the
// whole connection panel); outside the panels both shots are identical (the UI does not
// disturb the scene); the stereo shot has the wall in both halves, the two eyes differ.
// With GAUSS_HOST: also starts gauss-host on a free port and runs gauss-view against it
// (panels on) until it has drawn 200 frames; checks exit 0, no validation error, and that
// the shot is not all background.
//
// Exit code: 0 pass, 1 fail, 77 no display (CTest SKIP_RETURN_CODE).
#include <signal.h>
#include <sys/wait.h>
#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "gauss/engine/camera_io.h"
#include "gauss/engine/image_io.h"
#include "gauss/engine/ply_gaussian.h"
#include "child_process.h"
#include "view_run.h"

namespace {

using namespace gauss;
using namespace gauss::test;
namespace fs = std::filesystem;

constexpr std::uint32_t kW = kViewW, kH = kViewH;
// First-use panel layout of a window narrower than 1000 px (apps/gauss-view/panels_view.cpp):
// every panel collapsed, the title bars stacked in a 290 px column at x = 8 on each side
// (the right one from 640 - 298 = 342), 26 px apart from y = 8; so x in [300, 340) shows
// only the scene, and so does the left column below its fourth title bar.
constexpr std::uint32_t kFreeX0 = 300, kFreeX1 = 340;
// The connection panel: (8, 8), 290 wide; its title bar 19 px high when collapsed, the
// expanded panel 145 px high (a window 1000 px wide or more). Collapsed title bars follow
// each other every 26 px.
constexpr std::uint32_t kPanelX0 = 8, kPanelY0 = 8, kPanelX1 = 298, kPanelY1 = 153;
constexpr std::uint32_t kTitleH = 19, kTitleStep = 26;
// Below the left column's four collapsed title bars (8 + 3 * 26 + 19 = 105).
constexpr std::uint32_t kUnderTitlesY0 = 112;
// The large layout's window (wider than 1000 px, within the Xvfb screen).
constexpr std::uint32_t kLargeW = 1040, kLargeH = 640;

// Starts gauss-host as `host` on a free port (it prints the port on stdout); returns the
// port, 0 when it did not start or print one within 60 s.
int start_host(ChildProcess& host, const std::string& gauss_host, const fs::path& log) {
  // A log left by an earlier run would be read before the child writes its own.
  std::error_code ec;
  fs::remove(log, ec);
  if (!host.start({gauss_host, "--bind", "127.0.0.1:0", "--gaussians", "20000", "--duration", "240", "--quiet"}, log))
    return 0;
  for (int i = 0; i < 600; ++i) {  // up to 60 s for the scene to build
    const std::string text = read_text(log);
    const auto at = text.find("127.0.0.1:");
    if (at != std::string::npos) {
      const int port = std::atoi(text.c_str() + at + 10);
      if (port > 0) return port;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  fs::path out;
  if (auto rc = begin_window_test(argc, argv, "view_window", "view_window_test GAUSS_VIEW OUT_DIR [GAUSS_HOST]", out))
    return *rc;
  const std::string gauss_view = argv[1];

  const fs::path scene = out / "wall.ply";
  if (auto st = write_gaussian_ply(scene, wall()); !st) {
    std::fprintf(stderr, "view_window_test: %s\n", st.message().c_str());
    return 1;
  }
  const fs::path camera = out / "camera.json";
  if (auto st = write_wall_camera(camera); !st) {
    std::fprintf(stderr, "view_window_test: %s\n", st.message().c_str());
    return 1;
  }
  const std::vector<std::string> source{"--scene", scene.string(), "--camera", camera.string()};

  Shot ui = view_run("ui", gauss_view, source, out);
  std::vector<std::string> noui_args = source;
  noui_args.push_back("--no-ui");
  Shot noui = view_run("noui", gauss_view, noui_args, out);
  if (ui.ok && noui.ok) {
    const double cov = coverage(noui.image, 0, 0, kW, kH);
    check(cov > 0.5, "scene: " + std::to_string(cov * 100.0) + " % of the no-UI shot is not background (> 50 %)");
    // At 640x480 the panels start collapsed: the left column's four title bars show (over
    // the black background only their border and label differ, ~14 % of a bar), the scene
    // under where the expanded connection and stream panels were is left alone.
    for (std::uint32_t i = 0; i < 4; ++i) {
      const std::uint32_t y0 = kPanelY0 + i * kTitleStep;
      const double title = differing(ui.image, noui.image, kPanelX0, y0, kPanelX1, y0 + kTitleH);
      check(title > 0.05, "panels: collapsed title bar " + std::to_string(i) + " of the left column differs from the "
                          "scene alone in " + std::to_string(title * 100.0) + " % of its pixels (> 5 %)");
    }
    const double under = differing(ui.image, noui.image, kPanelX0, kUnderTitlesY0, kPanelX1, kH);
    check(under == 0.0, "small window: below the left column's title bars the scene is uncovered (" +
                            std::to_string(under * 100.0) + " % differ)");
    const double free = differing(ui.image, noui.image, kFreeX0, 0, kFreeX1, kH);
    check(free == 0.0, "outside the panels the UI and no-UI shots are identical (" + std::to_string(free * 100.0) +
                           " % differ)");
    check(coverage(noui.image, kFreeX0, 0, kFreeX1, kH) > 0.5, "the panel-free strip shows the scene");
  }
  // A window of kSmallWindowWidth or more starts with the panels expanded: the connection
  // panel covers its whole region.
  Shot large = view_run("ui_large", gauss_view, source, out, 12, kLargeW, kLargeH);
  Shot large_noui = view_run("noui_large", gauss_view, noui_args, out, 12, kLargeW, kLargeH);
  if (large.ok && large_noui.ok) {
    const double panel = differing(large.image, large_noui.image, kPanelX0, kPanelY0, kPanelX1, kPanelY1);
    check(panel > 0.5, "large window: the expanded connection panel region differs from the scene alone in " +
                           std::to_string(panel * 100.0) + " % of its pixels (> 50 %)");
  }

  std::vector<std::string> stereo_args = noui_args;
  stereo_args.insert(stereo_args.end(), {"--stereo", "0.2"});
  Shot stereo = view_run("stereo", gauss_view, stereo_args, out);
  if (stereo.ok) {
    const double left = coverage(stereo.image, 0, 0, kW / 2, kH), right = coverage(stereo.image, kW / 2, 0, kW, kH);
    check(left > 0.2 && right > 0.2, "stereo: the wall in both halves (" + std::to_string(left * 100.0) + " %, " +
                                         std::to_string(right * 100.0) + " % not background)");
    // The same view in both halves would make the halves equal: the eyes are 0.2 m apart.
    ImageRGBA8 l{kW / 2, kH, {}}, r{kW / 2, kH, {}};
    for (std::uint32_t y = 0; y < kH; ++y) {
      for (std::uint32_t x = 0; x < kW / 2; ++x) {
        l.pixels.insert(l.pixels.end(), px(stereo.image, x, y), px(stereo.image, x, y) + 4);
        r.pixels.insert(r.pixels.end(), px(stereo.image, x + kW / 2, y), px(stereo.image, x + kW / 2, y) + 4);
      }
    }
    const double d = differing(l, r, 0, 0, kW / 2, kH, 8);
    check(d > 0.05, "stereo: the eyes differ (" + std::to_string(d * 100.0) + " % of the pixels)");
  }

  if (argc >= 4) {
    ChildProcess host;
    const int port = start_host(host, argv[3], out / "gauss-host.log");
    check(port > 0, "gauss-host started and printed its port (" + std::to_string(port) + ")");
    if (port > 0) {
      Shot streamed = view_run("host", gauss_view, {"--host", "127.0.0.1:" + std::to_string(port)}, out, 200);
      if (streamed.ok) {
        const double cov = coverage(streamed.image, kFreeX0, 0, kFreeX1, kH);
        check(cov > 0.05, "host: the streamed scene shows between the panels (" + std::to_string(cov * 100.0) + " %)");
      }
      const std::string log = read_text(out / "gauss-host.log");
      std::printf("%s", log.c_str());
    }
    host.stop(SIGTERM);
  }
  std::printf("%s: %d failure(s); shots in %s\n", failures() ? "FAIL" : "PASS", failures(), out.c_str());
  return failures() ? 1 : 0;
}
