// gauss-view's command line.
#include "options.h"

#include <cctype>
#include <cmath>

#include "endpoint_option.h"
#include "gauss/engine/scene_up.h"
#include "gauss_cli.h"
#include "glfw.h"

namespace gauss::view {

double focal_from_hfov(double hfov_deg, std::uint32_t width) {
  return 0.5 * width / std::tan(hfov_deg * 3.14159265358979323846 / 360.0);
}

namespace {

// GLFW_KEY_* of a key name: a letter, a digit, or F1..F12; 0 when none.
int key_from_name(const std::string& name) {
  if (name.size() == 1 && std::isalnum(static_cast<unsigned char>(name[0])))
    return std::toupper(static_cast<unsigned char>(name[0]));  // GLFW's letter and digit keys are their ASCII
  if (name.size() >= 2 && (name[0] == 'F' || name[0] == 'f') && name.find_first_not_of("0123456789", 1) == std::string::npos) {
    const int n = std::stoi(name.substr(1));
    if (n >= 1 && n <= 12) return GLFW_KEY_F1 + n - 1;
  }
  return 0;
}

}  // namespace

std::optional<int> parse_options(int argc, char** argv, ViewOptions& o) {
  CLI::App app{
      "gauss-view: the desktop client. Connects to a gauss-host (--host) and shows the stream it\n"
      "receives, or views a scene file alone (--scene, the whole scene resident). Windowed by\n"
      "default (ImGui panels: connection, stream, scene, timing, objects and queries, view; drop a\n"
      "scene file on the window to open it, P writes a screenshot); --headless\n"
      "flies a camera path file and writes PNG frames plus one JSON line per frame instead (a\n"
      "scene without --path: a few frames from its default camera, which frames the scene's\n"
      "opacity-weighted 2nd..98th percentile box from outside, upright for --up; a host without\n"
      "--path: the view the host announces for its scene, upright for its up, held until the\n"
      "stream settles).",
      "gauss-view"};
  apps::configure(app);
  std::string host, mode = o.mode == PublishMode::Immediate ? "immediate" : "progressive", size;
  size = std::to_string(o.width) + "x" + std::to_string(o.height);
  auto* host_opt = app.add_option("--host", host, "the gauss-host to connect to, HOST:PORT")
                       ->check(apps::endpoint())
                       ->type_name("HOST:PORT");
  auto* scene_opt =
      app.add_option("--scene", o.scene, "view this scene file (3DGS PLY, compressed PLY, .splat, SPZ or SOG) alone")
          ->check(CLI::ExistingPath);
  host_opt->excludes(scene_opt);
  app.add_option("--mesh", o.mesh, "with --scene: a surface mesh PLY drawn behind the splats")
      ->check(CLI::ExistingFile)
      ->needs(scene_opt);
  app.add_option("--token", o.token, "access token the host requires, or the pairing code it printed");
  app.add_option("--name", o.name, "client name the host logs (and names its dumps after)");
  app.add_option("--budget", o.budget, "M: Gaussian slots of this client")->check(apps::in_range<std::uint32_t>(1, 400000));
  app.add_option("--mode", mode, "publication mode")->check(CLI::IsMember({"progressive", "immediate"}));
  bool no_highlight = false;
  app.add_flag("--no-highlight", no_highlight, "do not tint the objects of the active query");
  app.add_flag("--edit-tints", o.edit_tints, "tint Gaussians as they are added, changed or removed");
  app.add_option("--frames-in-flight", o.frames_in_flight, "frames the GPU may work on at once")
      ->check(apps::in_range<std::uint32_t>(1, 4));
  apps::add_on_off(app, "--publication-thread", o.publication_thread,
                   "with --host: publish the stream and pack its uploads on a thread of their own, so the display "
                   "thread only hands them over");
  app.add_option("--size", size, "view size (headless: unless the path file gives a camera); windowed: the window's size")->check(apps::image_size());
  app.add_option("--fov", o.fov_deg, "horizontal field of view in degrees of the default camera")
      ->check(apps::in_range(10.0, 150.0));
  apps::add_up_option(app, o.up,
                      "the scene's up axis: +x -x +y -y +z -z (default: a local scene's trainer cameras.json beside "
                      "it gives the capture's up, else -y, the 3DGS/COLMAP convention; a stream: the up its host "
                      "announces)");
  std::string view = "front";
  app.add_option("--view", view,
                 "the default camera's view of a local scene: front (the capture's side), side (its right), top "
                 "(from above)")
      ->check(CLI::IsMember({"front", "side", "top"}));
  app.add_option("--stereo", o.stereo_ipd, "render both eyes this far apart (metres; 0: one view)")
      ->check(apps::in_range(0.0, 1.0));
  app.add_option("--device", o.device, "Vulkan device index or name substring");

  app.add_flag("--headless", o.headless,
               "no window: fly --path (without it: a scene's default camera, or the window's first view of a "
               "host's scene), write frames to --out");
  auto* path_opt = app.add_option("--path", o.path, "camera path JSON (see client/camera_path.h)")->check(CLI::ExistingFile);
  app.add_option("--out", o.out, "headless: folder for frames, frames.jsonl and summary.json");
  app.add_option("--every", o.every, "headless: write every Nth frame as PNG (0: only the final frame)");
  app.add_option("--settle-timeout", o.settle_timeout_s, "headless: seconds to wait after the path for the stream to settle")
      ->check(apps::in_range(0.0, 3600.0));
  app.add_option("--quiet-time", o.quiet_s, "headless: settled = nothing pending and no edits for this many seconds")
      ->check(apps::in_range(0.0, 600.0));
  app.add_option("--max-frames", o.max_frames, "headless: stop after this many frames (windowed: --exit-after)")->check(apps::at_least<std::uint64_t>(1));
  app.add_option("--screenshot", o.screenshot, "windowed: write the window (scene + panels) as PNG");
  app.add_option("--screenshot-after", o.screenshot_after, "windowed: frames before the screenshot");
  app.add_option("--exit-after", o.exit_after, "windowed: close after this many frames (0: never)");
  app.add_flag("--no-ui", o.no_ui, "windowed: no panels, the scene alone");
  app.add_option("--camera", o.camera, "windowed: start at this camera's pose (camera JSON)")->check(CLI::ExistingFile);
  app.add_option("--screenshot-dir", o.screenshot_dir,
                 "windowed: where the P key writes gauss-view-NNNN.png (the first free number)")
      ->check(CLI::ExistingDirectory);
  app.add_option("--drop", o.drop,
                 "windowed, for scripts and tests: drop this file on the window after --drop-after frames; "
                 "--exit-after and --screenshot-after then count the frames after its load ended");
  app.add_option("--drop-after", o.drop_after, "windowed: frames before --drop");
  std::string press;
  app.add_option("--press", press, "windowed, for scripts and tests: press this key (a letter, digit or F1..F12) "
                                   "after --press-after frames")
      ->check(CLI::Validator([](std::string& in) { return key_from_name(in) != 0 ? std::string() : "no such key: " + in; },
                             ""))
      ->type_name("KEY");
  app.add_option("--press-after", o.press_after, "windowed: frames before --press");

  if (auto rc = apps::parse(app, argc, argv)) return rc;
  if (host.empty() && o.scene.empty()) {
    std::fprintf(stderr, "gauss-view: give --host HOST:PORT or --scene FILE\nRun with --help for more information.\n");
    return apps::kUsageError;
  }
  (void)path_opt;
  if (!host.empty()) o.host = *net::parse_endpoint(host);
  o.mode = mode == "immediate" ? PublishMode::Immediate : PublishMode::Progressive;
  o.highlight = !no_highlight;
  o.press_key = key_from_name(press);
  o.view = view == "side" ? ViewPreset::Side : view == "top" ? ViewPreset::Top : ViewPreset::Front;
  const auto wh = apps::parse_size(size);
  o.width = wh->first;
  o.height = wh->second;
  return std::nullopt;
}

}  // namespace gauss::view
