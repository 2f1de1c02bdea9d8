// view_window_test: gauss-view's windowed mode end to end, on a real window (Xvfb in CI:
// xvfb-run -a -s "-screen 0 1280x800x24" view_window_test GAUSS_VIEW OUT_DIR [GAUSS_HOST]).
//
// Writes a 2000-Gaussian scene (a coloured wall 3 m in front of the camera) and a camera
// JSON, then runs gauss-view windowed on it (640x480, 12 frames, a screenshot of frame 9):
//   ui      the panels on (the default);
//   noui    --no-ui: the scene alone;
//   stereo  --no-ui --stereo 0.2: two eyes side by side.
// Checks: every run exits 0 with no validation error line on stderr; the scene shows
// (the no-UI shot is mostly not background); the panels show (the UI shot differs from
// the no-UI shot over the connection panel); outside the panels both shots are identical
// (the UI does not disturb the scene); the stereo shot has the wall in both halves, the
// two eyes differ.
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
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "gauss/engine/camera_io.h"
#include "gauss/engine/image_io.h"
#include "gauss/engine/ply_gaussian.h"

namespace {

using namespace gauss;
namespace fs = std::filesystem;

constexpr std::uint32_t kW = 640, kH = 480;
constexpr int kTimeoutS = 300;
// First-use panel layout of a window narrower than 1000 px (apps/gauss-view/panels_view.cpp):
// a 290 px column at x = 8 on each side (the right one from 640 - 298 = 342), so x in
// [300, 340) shows only the scene.
constexpr std::uint32_t kFreeX0 = 300, kFreeX1 = 340;
// The connection panel: (8, 8), 290 x 145.
constexpr std::uint32_t kPanelX0 = 8, kPanelY0 = 8, kPanelX1 = 298, kPanelY1 = 153;

int failures = 0;
void check(bool ok, const std::string& what) {
  std::printf("%s %s\n", ok ? "ok  " : "FAIL", what.c_str());
  std::fflush(stdout);
  if (!ok) ++failures;
}

// Runs argv with stdout and stderr into `log`; kills it (its pid only) after kTimeoutS.
// Returns the exit status, or -1 (timeout / signal / could not start).
int run(const std::vector<std::string>& argv, const fs::path& log) {
  std::printf("run:");
  for (const auto& a : argv) std::printf(" %s", a.c_str());
  std::printf("\n");
  std::fflush(stdout);
  const pid_t pid = fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      dup2(fd, 1);
      dup2(fd, 2);
      close(fd);
    }
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    execv(args[0], args.data());
    _exit(127);
  }
  const auto t0 = std::chrono::steady_clock::now();
  for (;;) {
    int status = 0;
    const pid_t r = waitpid(pid, &status, WNOHANG);
    if (r == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    if (std::chrono::steady_clock::now() - t0 > std::chrono::seconds(kTimeoutS)) {
      std::printf("timeout: killing pid %d\n", static_cast<int>(pid));
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

bool has_validation_error(const std::string& log) { return log.find("[vulkan validation ERROR]") != std::string::npos; }

const std::uint8_t* px(const ImageRGBA8& img, std::uint32_t x, std::uint32_t y) {
  return &img.pixels[(std::size_t{y} * img.width + x) * 4];
}
bool background(const std::uint8_t* p) { return p[0] < 8 && p[1] < 8 && p[2] < 8; }

// Fraction of [x0,x1)x[y0,y1) that is not background.
double coverage(const ImageRGBA8& img, std::uint32_t x0, std::uint32_t y0, std::uint32_t x1, std::uint32_t y1) {
  std::size_t n = 0, total = 0;
  for (std::uint32_t y = y0; y < y1; ++y)
    for (std::uint32_t x = x0; x < x1; ++x, ++total) n += background(px(img, x, y)) ? 0 : 1;
  return total ? static_cast<double>(n) / static_cast<double>(total) : 0.0;
}

// Fraction of [x0,x1)x[y0,y1) where a and b differ (any channel by more than `tol`).
double differing(const ImageRGBA8& a, const ImageRGBA8& b, std::uint32_t x0, std::uint32_t y0, std::uint32_t x1,
                 std::uint32_t y1, int tol = 0) {
  std::size_t n = 0, total = 0;
  for (std::uint32_t y = y0; y < y1; ++y) {
    for (std::uint32_t x = x0; x < x1; ++x, ++total) {
      const std::uint8_t* p = px(a, x, y);
      const std::uint8_t* q = px(b, x, y);
      for (int c = 0; c < 3; ++c) {
        if (std::abs(int{p[c]} - int{q[c]}) > tol) {
          ++n;
          break;
        }
      }
    }
  }
  return total ? static_cast<double>(n) / static_cast<double>(total) : 0.0;
}

// A 50 x 40 wall of Gaussians at z = 3, 3 m x 2.2 m, colours varying across it.
GaussianCloud wall() {
  GaussianCloud cloud;
  for (int j = 0; j < 40; ++j) {
    for (int i = 0; i < 50; ++i) {
      Gaussian g;
      g.position = {-1.5f + 0.06f * i, -1.1f + 0.055f * j, 3.0f};
      g.log_scale = glm::vec3(std::log(0.035f), std::log(0.035f), std::log(0.01f));
      g.opacity_logit = 3.0f;
      const glm::vec3 colour(i / 49.0f, j / 39.0f, 1.0f - i / 49.0f);
      g.sh_dc = (colour - 0.5f) / 0.2821f;
      g.id = GaussianId{static_cast<std::uint64_t>(j * 50 + i + 1)};
      cloud.gaussians.push_back(g);
    }
  }
  return cloud;
}

struct Shot {
  bool ok{false};
  ImageRGBA8 image;
};

Shot view_run(const std::string& name, const std::string& gauss_view, std::vector<std::string> extra,
              const fs::path& out, std::uint64_t frames = 12) {
  const fs::path png = out / (name + ".png");
  const fs::path log = out / (name + ".log");
  fs::remove(png);
  std::vector<std::string> argv{gauss_view, "--size", std::to_string(kW) + "x" + std::to_string(kH),
                                "--exit-after", std::to_string(frames), "--screenshot", png.string(),
                                "--screenshot-after", std::to_string(frames - 4)};
  argv.insert(argv.end(), extra.begin(), extra.end());
  const int rc = run(argv, log);
  const std::string text = read_text(log);
  check(rc == 0, name + ": gauss-view exits 0 (got " + std::to_string(rc) + "; log " + log.string() + ")");
  check(!has_validation_error(text), name + ": no validation error on stderr");
  Shot s;
  auto img = read_png_rgba8(png);
  check(img.ok(), name + ": screenshot " + png.string() + (img ? "" : ": " + img.message()));
  if (!img) return s;
  check(img->width == kW && img->height == kH,
        name + ": screenshot is " + std::to_string(img->width) + "x" + std::to_string(img->height));
  s.ok = rc == 0 && img->width == kW && img->height == kH;
  s.image = std::move(*img);
  return s;
}

// Starts gauss-host on a free port (it prints the port on stdout); returns its pid and port.
std::pair<pid_t, int> start_host(const std::string& gauss_host, const fs::path& log) {
  // A log left by an earlier run would be read before the child truncates it.
  std::error_code ec;
  fs::remove(log, ec);
  const pid_t pid = fork();
  if (pid < 0) return {-1, 0};
  if (pid == 0) {
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      dup2(fd, 1);
      dup2(fd, 2);
      close(fd);
    }
    execl(gauss_host.c_str(), gauss_host.c_str(), "--bind", "127.0.0.1:0", "--gaussians", "20000", "--duration", "240",
          "--quiet", static_cast<char*>(nullptr));
    _exit(127);
  }
  for (int i = 0; i < 600; ++i) {  // up to 60 s for the scene to build
    const std::string text = read_text(log);
    const auto at = text.find("127.0.0.1:");
    if (at != std::string::npos) {
      const int port = std::atoi(text.c_str() + at + 10);
      if (port > 0) return {pid, port};
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return {pid, 0};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: view_window_test GAUSS_VIEW OUT_DIR [GAUSS_HOST]\n");
    return 2;
  }
  if (std::getenv("DISPLAY") == nullptr && std::getenv("WAYLAND_DISPLAY") == nullptr) {
    std::printf("no display: skipped (run under xvfb-run)\n");
    return 77;
  }
  const std::string gauss_view = argv[1];
  const fs::path out = fs::path(argv[2]) / "view_window";
  std::error_code ec;
  fs::create_directories(out, ec);

  const fs::path scene = out / "wall.ply";
  if (auto st = write_gaussian_ply(scene, wall()); !st) {
    std::fprintf(stderr, "view_window_test: %s\n", st.message().c_str());
    return 1;
  }
  Camera cam;
  cam.width = kW;
  cam.height = kH;
  cam.fx = cam.fy = 500.0;
  cam.cx = kW / 2.0;
  cam.cy = kH / 2.0;
  const fs::path camera = out / "camera.json";
  if (auto st = write_camera_json(camera, cam); !st) {
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
    const double panel = differing(ui.image, noui.image, kPanelX0, kPanelY0, kPanelX1, kPanelY1);
    check(panel > 0.5, "panels: the connection panel region differs from the scene alone in " +
                           std::to_string(panel * 100.0) + " % of its pixels (> 50 %)");
    const double free = differing(ui.image, noui.image, kFreeX0, 0, kFreeX1, kH);
    check(free == 0.0, "outside the panels the UI and no-UI shots are identical (" + std::to_string(free * 100.0) +
                           " % differ)");
    check(coverage(noui.image, kFreeX0, 0, kFreeX1, kH) > 0.5, "the panel-free strip shows the scene");
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
    const auto [host_pid, port] = start_host(argv[3], out / "gauss-host.log");
    check(host_pid > 0 && port > 0, "gauss-host started and printed its port (" + std::to_string(port) + ")");
    if (host_pid > 0 && port > 0) {
      Shot streamed = view_run("host", gauss_view, {"--host", "127.0.0.1:" + std::to_string(port)}, out, 200);
      if (streamed.ok) {
        const double cov = coverage(streamed.image, kFreeX0, 0, kFreeX1, kH);
        check(cov > 0.05, "host: the streamed scene shows between the panels (" + std::to_string(cov * 100.0) + " %)");
      }
      const std::string log = read_text(out / "gauss-host.log");
      std::printf("%s", log.c_str());
    }
    if (host_pid > 0) {
      kill(host_pid, SIGTERM);
      int status = 0;
      waitpid(host_pid, &status, 0);
    }
  }
  std::printf("%s: %d failure(s); shots in %s\n", failures ? "FAIL" : "PASS", failures, out.c_str());
  return failures ? 1 : 0;
}
