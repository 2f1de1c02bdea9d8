#pragma once
// What the gauss-view window tests share (view_window_test, view_drop_test): pass/fail
// lines, running gauss-view windowed with a screenshot, comparing shots, and the test
// scenes. Header only: each test is its own executable under xvfb-run.
#include <signal.h>
#include <sys/wait.h>
#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "gauss/engine/camera.h"
#include "gauss/engine/camera_io.h"
#include "gauss/engine/gaussian.h"
#include "gauss/engine/image_io.h"
#include "text_file.h"

namespace gauss::test {

namespace fs = std::filesystem;

inline constexpr std::uint32_t kViewW = 640, kViewH = 480;
inline constexpr int kViewTimeoutS = 300;

inline int& failures() {
  static int n = 0;
  return n;
}
inline bool check(bool ok, const std::string& what) {
  std::printf("%s %s\n", ok ? "ok  " : "FAIL", what.c_str());
  std::fflush(stdout);
  if (!ok) ++failures();
  return ok;
}

// Exit code 77 (CTest's SKIP_RETURN_CODE) when there is no display to open a window on.
inline bool have_display() { return std::getenv("DISPLAY") != nullptr || std::getenv("WAYLAND_DISPLAY") != nullptr; }

// Runs argv with stdout and stderr into `log`; kills it (its pid only) after kViewTimeoutS.
// Returns the exit status, or -1 (timeout / signal / could not start).
inline int run(const std::vector<std::string>& argv, const fs::path& log) {
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
    if (std::chrono::steady_clock::now() - t0 > std::chrono::seconds(kViewTimeoutS)) {
      std::printf("timeout: killing pid %d\n", static_cast<int>(pid));
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

inline bool has_validation_error(const std::string& log) {
  return log.find("[vulkan validation ERROR]") != std::string::npos;
}

inline const std::uint8_t* px(const ImageRGBA8& img, std::uint32_t x, std::uint32_t y) {
  return &img.pixels[(std::size_t{y} * img.width + x) * 4];
}
inline bool background(const std::uint8_t* p) { return p[0] < 8 && p[1] < 8 && p[2] < 8; }

// Fraction of [x0,x1)x[y0,y1) that is not background.
inline double coverage(const ImageRGBA8& img, std::uint32_t x0, std::uint32_t y0, std::uint32_t x1, std::uint32_t y1) {
  std::size_t n = 0, total = 0;
  for (std::uint32_t y = y0; y < y1; ++y)
    for (std::uint32_t x = x0; x < x1; ++x, ++total) n += background(px(img, x, y)) ? 0 : 1;
  return total ? static_cast<double>(n) / static_cast<double>(total) : 0.0;
}

// Fraction of [x0,x1)x[y0,y1) where a and b differ (any channel by more than `tol`).
inline double differing(const ImageRGBA8& a, const ImageRGBA8& b, std::uint32_t x0, std::uint32_t y0, std::uint32_t x1,
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
inline GaussianCloud wall() {
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

// The tests' command line, GAUSS_VIEW OUT_DIR [...]: std::nullopt to go on (with `out` =
// OUT_DIR/`name`, created), else the exit code: 2 for a short command line, 77 without a
// display.
inline std::optional<int> begin_window_test(int argc, char** argv, const std::string& name, const char* usage,
                                            fs::path& out) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s\n", usage);
    return 2;
  }
  if (!have_display()) {
    std::printf("no display: skipped (run under xvfb-run)\n");
    return 77;
  }
  out = fs::path(argv[2]) / name;
  std::error_code ec;
  fs::create_directories(out, ec);
  return std::nullopt;
}

// Writes the camera the wall is seen from: at the origin looking down +z, kViewW x kViewH,
// 500 px focal length. Errors: the writer's.
inline Status write_wall_camera(const fs::path& path) {
  Camera cam;
  cam.width = kViewW;
  cam.height = kViewH;
  cam.fx = cam.fy = 500.0;
  cam.cx = kViewW / 2.0;
  cam.cy = kViewH / 2.0;
  return write_camera_json(path, cam);
}

struct Shot {
  bool ok{false};
  int rc{-1};
  std::string log;  // gauss-view's stdout + stderr
  ImageRGBA8 image;
};

// Runs gauss-view windowed at `w` x `h` for `frames` frames with a screenshot of frame
// frames - 4 (`extra`: the source and anything else), into `out`/`name`.png and .log.
// Checks exit 0, no validation error, a screenshot of the window's size.
inline Shot view_run(const std::string& name, const std::string& gauss_view, const std::vector<std::string>& extra,
                     const fs::path& out, std::uint64_t frames = 12, std::uint32_t w = kViewW, std::uint32_t h = kViewH) {
  const fs::path png = out / (name + ".png");
  const fs::path log = out / (name + ".log");
  fs::remove(png);
  std::vector<std::string> argv{gauss_view, "--size", std::to_string(w) + "x" + std::to_string(h),
                                "--exit-after", std::to_string(frames), "--screenshot", png.string(),
                                "--screenshot-after", std::to_string(frames - 4)};
  argv.insert(argv.end(), extra.begin(), extra.end());
  Shot s;
  s.rc = run(argv, log);
  s.log = read_text(log);
  check(s.rc == 0, name + ": gauss-view exits 0 (got " + std::to_string(s.rc) + "; log " + log.string() + ")");
  check(!has_validation_error(s.log), name + ": no validation error on stderr");
  auto img = read_png_rgba8(png);
  check(img.ok(), name + ": screenshot " + png.string() + (img ? "" : ": " + img.message()));
  if (!img) return s;
  check(img->width == w && img->height == h,
        name + ": screenshot is " + std::to_string(img->width) + "x" + std::to_string(img->height));
  s.ok = s.rc == 0 && img->width == w && img->height == h;
  s.image = std::move(*img);
  return s;
}

}  // namespace gauss::test
