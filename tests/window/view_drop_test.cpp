// view_drop_test: gauss-view's files on a real window (Xvfb in CI:
// xvfb-run -a -s "-screen 0 1280x800x24" view_drop_test GAUSS_VIEW OUT_DIR).
//
// Every run starts on a coloured wall seen from a fixed --camera (640x480) and drops a file
// on the window with --drop, which goes through the window's drop handler as GLFW's drop
// callback does; the shot is of a frame after the load ended (options.h).
//   base         no drop, --no-ui: the wall as it is shown.
//   ball         a red ball far behind the start camera: it opens (the log says so) and is
//                framed by the default camera (red in the middle of the shot, which differs
//                from base).
//   one          a single green Gaussian: framed (the log's framing looks at it; green in
//                the middle).
//   garbage, truncated, nan, missing, unreadable (not as root: root reads anything), folder
//                bad files: gauss-view goes on (exit 0), the shot equals base pixel for
//                pixel, the log has the reader's message naming the file. nan is a PLY whose
//                centres are all NaN: every reader refuses non-finite values (splat_file.h),
//                so a scene without a finite centre never reaches the viewer's framing (which
//                would give it the unit box, scene_framing.h).
//   garbage_ui   the same with the panels: the message shows over the bottom of the scene
//                (that region differs from the no-UI shot), the rest of the scene does not.
//   guitar       the shared guitar.compressed.ply (skipped without ../shared/data): opens,
//                framed (what it covers spans most of the window's height, centred).
//   key          --press p: the screenshot key writes gauss-view-0002.png in --screenshot-dir
//                (0001 exists and is left alone), the size of the window, the same pixels
//                as the --screenshot of the same static view; the log names its path.
//
// Exit code: 0 pass, 1 fail, 77 no display (CTest SKIP_RETURN_CODE).
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "gauss/engine/camera_io.h"
#include "gauss/engine/image_io.h"
#include "gauss/engine/ply_gaussian.h"
#include "test_data.h"
#include "view_run.h"

namespace {

using namespace gauss;
using namespace gauss::test;

constexpr std::uint32_t kW = kViewW, kH = kViewH;
// Frames of each run, counted after the drop's load ended; the shot is of frame kFrames - 4.
constexpr std::uint64_t kFrames = 6;

Gaussian splat(glm::vec3 at, float scale, glm::vec3 colour, std::uint64_t id) {
  Gaussian g;
  g.position = at;
  g.log_scale = glm::vec3(std::log(scale));
  g.opacity_logit = 4.0f;
  g.sh_dc = (colour - 0.5f) / 0.2821f;
  g.id = GaussianId{id};
  return g;
}

// A red ball of radius 0.5 m around (-30, 10, -40): behind the wall's camera (which looks
// down +z from the origin), so only the dropped scene's own framing shows it.
GaussianCloud ball() {
  GaussianCloud cloud;
  const glm::vec3 centre(-30.0f, 10.0f, -40.0f);
  std::uint64_t id = 1;
  for (int i = 0; i < 12; ++i) {
    for (int j = 0; j < 24; ++j) {
      const float theta = 3.14159265f * (i + 0.5f) / 12.0f, phi = 6.2831853f * j / 24.0f;
      const glm::vec3 n(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
      cloud.gaussians.push_back(splat(centre + 0.5f * n, 0.08f, {1.0f, 0.05f, 0.05f}, id++));
    }
  }
  return cloud;
}

// Pixels of the 2 half x 2 half box at the shot's centre where channel `c` (0 red, 1 green)
// clearly dominates.
double dominant_share(const ImageRGBA8& img, std::uint32_t half, int c) {
  std::size_t n = 0, total = 0;
  for (std::uint32_t y = kH / 2 - half; y < kH / 2 + half; ++y) {
    for (std::uint32_t x = kW / 2 - half; x < kW / 2 + half; ++x, ++total) {
      const std::uint8_t* p = px(img, x, y);
      n += (p[c] > 60 && p[c] > 2 * p[(c + 1) % 3] && p[c] > 2 * p[(c + 2) % 3]) ? 1 : 0;
    }
  }
  return static_cast<double>(n) / static_cast<double>(total);
}

// The first and last rows with a pixel that is not background ({0, 0} when none).
std::pair<int, int> covered_rows(const ImageRGBA8& img) {
  int top = -1, bottom = 0;
  for (std::uint32_t y = 0; y < img.height; ++y) {
    for (std::uint32_t x = 0; x < img.width; ++x) {
      if (background(px(img, x, y))) continue;
      if (top < 0) top = static_cast<int>(y);
      bottom = static_cast<int>(y);
      break;
    }
  }
  return {std::max(top, 0), bottom};
}

bool contains(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

// The "framed from X Y Z looking at X Y Z" line gauss-view prints after opening a scene.
bool framing_line(const std::string& log, double (&eye)[3], double (&target)[3]) {
  const auto at = log.find("framed from ");
  if (at == std::string::npos) return false;
  return std::sscanf(log.c_str() + at, "framed from %lf %lf %lf looking at %lf %lf %lf", &eye[0], &eye[1], &eye[2],
                     &target[0], &target[1], &target[2]) == 6;
}

bool write_bytes(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary);
  out << bytes;
  return static_cast<bool>(out);
}

}  // namespace

int main(int argc, char** argv) {
  fs::path out;
  if (auto rc = begin_window_test(argc, argv, "view_drop", "view_drop_test GAUSS_VIEW OUT_DIR", out)) return *rc;
  const std::string gauss_view = argv[1];
  std::error_code ec;
  fs::remove_all(out, ec);  // the shots folder's numbered files start again from 0001
  fs::create_directories(out, ec);

  // The scenes.
  const fs::path wall_ply = out / "wall.ply", ball_ply = out / "ball.ply", one_ply = out / "one.ply",
                 nan_ply = out / "nan.ply";
  GaussianCloud one;
  one.gaussians.push_back(splat({3.0f, -2.0f, 7.0f}, 0.2f, {0.1f, 1.0f, 0.1f}, 1));
  // The writer refuses non-finite centres: write a marker value and turn its bytes into NaN.
  constexpr float kMarker = 12345.5f;
  GaussianCloud nan = ball();
  for (Gaussian& g : nan.gaussians) g.position = glm::vec3(kMarker);
  for (const auto& [path, cloud] : {std::pair{wall_ply, wall()}, std::pair{ball_ply, ball()}, std::pair{one_ply, one},
                                    std::pair{nan_ply, nan}}) {
    if (auto st = write_gaussian_ply(path, cloud); !st) {
      std::fprintf(stderr, "view_drop_test: %s\n", st.message().c_str());
      return 1;
    }
  }
  {
    std::string bytes = read_text(nan_ply);
    const float quiet_nan = std::nanf("");
    std::string marker(4, '\0'), nan_bytes(4, '\0');
    std::memcpy(marker.data(), &kMarker, 4);
    std::memcpy(nan_bytes.data(), &quiet_nan, 4);
    std::size_t replaced = 0;
    for (auto at = bytes.find(marker); at != std::string::npos; at = bytes.find(marker, at + 4), ++replaced)
      bytes.replace(at, 4, nan_bytes);
    if (replaced != 3 * nan.gaussians.size() || !write_bytes(nan_ply, bytes)) {
      std::fprintf(stderr, "view_drop_test: %s: %zu of %zu centre values made NaN\n", nan_ply.c_str(), replaced,
                   3 * nan.gaussians.size());
      return 1;
    }
  }
  // Bad files: random bytes, a PLY whose body stops early, a path that does not exist, a
  // file nobody may read, a folder that is no SOG.
  const fs::path garbage = out / "garbage.ply", truncated = out / "truncated.ply", missing = out / "missing.ply",
                 unreadable = out / "unreadable.ply", folder = out / "folder";
  std::string noise(4096, '\0');
  std::uint32_t state = 12345;
  for (char& c : noise) {
    state = state * 1664525u + 1013904223u;
    c = static_cast<char>(state >> 24);
  }
  const std::string wall_bytes = read_text(wall_ply);
  if (!write_bytes(garbage, noise) || !write_bytes(truncated, wall_bytes.substr(0, wall_bytes.size() / 2)) ||
      !write_bytes(unreadable, wall_bytes)) {
    std::fprintf(stderr, "view_drop_test: cannot write the bad files in %s\n", out.c_str());
    return 1;
  }
  fs::create_directories(folder, ec);
  chmod(unreadable.c_str(), 0);
  const fs::path camera = out / "camera.json";
  if (auto st = write_wall_camera(camera); !st) {
    std::fprintf(stderr, "view_drop_test: %s\n", st.message().c_str());
    return 1;
  }
  const std::vector<std::string> start{"--scene", wall_ply.string(), "--camera", camera.string()};
  const auto args = [&](const fs::path& drop, bool ui) {
    std::vector<std::string> a = start;
    if (!ui) a.push_back("--no-ui");
    if (!drop.empty()) a.insert(a.end(), {"--drop", drop.string()});
    return a;
  };

  const Shot base = view_run("base", gauss_view, args({}, false), out, kFrames);
  if (!base.ok) {
    std::printf("FAIL: no baseline shot\n");
    return 1;
  }

  // A scene that opens replaces the wall and is framed by its default camera.
  const Shot dropped = view_run("ball", gauss_view, args(ball_ply, false), out, kFrames);
  if (dropped.ok) {
    check(contains(dropped.log, "opened scene ball.ply"), "ball: the log says it opened");
    const double red = dominant_share(dropped.image, 20, 0);
    check(red > 0.5, "ball: the dropped ball is framed, red in " + std::to_string(red * 100.0) +
                         " % of the middle 40x40 (> 50 %)");
    const double d = differing(dropped.image, base.image, 0, 0, kW, kH);
    check(d > 0.5, "ball: the shot differs from the wall's in " + std::to_string(d * 100.0) + " % (> 50 %)");
  }

  // A single Gaussian and a scene without finite centres still get a sensible camera.
  const Shot single = view_run("one", gauss_view, args(one_ply, false), out, kFrames);
  if (single.ok) {
    double eye[3], target[3];
    check(framing_line(single.log, eye, target) && std::abs(target[0] - 3.0) < 1e-3 && std::abs(target[1] + 2.0) < 1e-3 &&
              std::abs(target[2] - 7.0) < 1e-3,
          "one: framed looking at the Gaussian (3, -2, 7)");
    const double green = dominant_share(single.image, 10, 1);
    check(green > 0.9, "one: the green Gaussian shows in the middle (" + std::to_string(green * 100.0) +
                           " % of the middle 20x20 green, > 90 %)");
  }

  // Bad files change nothing but the message.
  std::vector<std::pair<std::string, fs::path>> bad{
      {"garbage", garbage}, {"truncated", truncated}, {"nan", nan_ply}, {"missing", missing}, {"folder", folder}};
  if (geteuid() != 0) {
    bad.emplace_back("unreadable", unreadable);
  } else {
    std::printf("skip unreadable: running as root, which reads a file of mode 000\n");
  }
  Shot garbage_noui;
  for (const auto& [name, path] : bad) {
    Shot s = view_run(name, gauss_view, args(path, false), out, kFrames);
    if (!s.ok) continue;
    check(contains(s.log, "could not open " + path.string() + ": " + path.string()),
          name + ": the log has the reader's message naming the file");
    check(!contains(s.log, "opened scene"), name + ": nothing opened");
    const double d = differing(s.image, base.image, 0, 0, kW, kH);
    check(d == 0.0, name + ": the wall is still shown, unchanged (" + std::to_string(d * 100.0) + " % differ)");
    if (name == "garbage") garbage_noui = std::move(s);
  }
  const Shot garbage_ui = view_run("garbage_ui", gauss_view, args(garbage, true), out, kFrames);
  if (garbage_ui.ok && garbage_noui.ok) {
    // The message: bottom centre, up to 560 px wide (panels_scene.cpp draw_notices).
    const double msg = differing(garbage_ui.image, garbage_noui.image, 120, kH - 40, kW - 120, kH - 12);
    check(msg > 0.3, "garbage_ui: the error shows over the bottom of the scene (" + std::to_string(msg * 100.0) +
                         " % of it differs, > 30 %)");
    const double rest = differing(garbage_ui.image, garbage_noui.image, 300, 112, 340, 300);
    check(rest == 0.0, "garbage_ui: above it the scene is untouched (" + std::to_string(rest * 100.0) + " % differ)");
  }

  // A shared real scene, dropped.
  if (const auto guitar = data_file("splats/guitar.compressed.ply")) {
    const Shot g = view_run("guitar", gauss_view, args(*guitar, false), out, kFrames);
    if (g.ok) {
      check(contains(g.log, "opened scene guitar.compressed.ply"), "guitar: the log says it opened");
      // Seen edge-on from the front (the capture's convention), it is tall and thin: its
      // rows, not its area, say whether it is framed.
      const auto [top, bottom] = covered_rows(g.image);
      check(bottom - top > 0.6 * kH && std::abs(0.5 * (top + bottom) - 0.5 * kH) < 0.15 * kH,
            "guitar: framed, covering rows " + std::to_string(top) + ".." + std::to_string(bottom) +
                " (more than 60 % of the height, centred within 15 %)");
    }
  } else {
    std::printf("skip guitar: no splats/guitar.compressed.ply under the shared data folder (GAUSS_DATA_DIR)\n");
  }

  // The screenshot key: a new numbered PNG, never over an existing one.
  const fs::path shots = out / "shots";
  fs::create_directories(shots, ec);
  write_bytes(shots / "gauss-view-0001.png", "keep");
  std::vector<std::string> key_args = args({}, false);
  key_args.insert(key_args.end(), {"--press", "p", "--press-after", "3", "--screenshot-dir", shots.string()});
  const Shot key = view_run("key", gauss_view, key_args, out, 10);
  const fs::path written = shots / "gauss-view-0002.png";
  check(read_text(shots / "gauss-view-0001.png") == "keep", "key: the existing gauss-view-0001.png is left alone");
  check(contains(key.log, "wrote " + fs::absolute(written).string()), "key: the log names " + written.string());
  auto png = read_png_rgba8(written);
  if (check(png.ok(), "key: " + written.string() + " decodes" + (png ? "" : ": " + png.message()))) {
    check(png->width == kW && png->height == kH,
          "key: it is the window's size (" + std::to_string(png->width) + "x" + std::to_string(png->height) + ")");
    if (key.ok && png->width == kW && png->height == kH) {
      const double d = differing(*png, key.image, 0, 0, kW, kH);
      check(d == 0.0, "key: it shows the window as --screenshot does (" + std::to_string(d * 100.0) + " % differ)");
    }
  }

  std::printf("%s: %d failure(s); shots in %s\n", failures() ? "FAIL" : "PASS", failures(), out.c_str());
  return failures() ? 1 : 0;
}
