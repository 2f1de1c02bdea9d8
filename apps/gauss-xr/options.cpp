// gauss-xr's command line.
#include "options.h"

#include "endpoint_option.h"
#include "gauss_cli.h"

namespace gauss::xr_app {

std::optional<int> parse_options(int argc, char** argv, XrOptions& o) {
  CLI::App app{
      "gauss-xr: the headset client. Renders the stream from a gauss-host in stereo through the\n"
      "active OpenXR runtime (XR_KHR_vulkan_enable2; XR_RUNTIME_JSON selects one). Right controller:\n"
      "point and pull the trigger to query the object under the ray, A for the next object class,\n"
      "B to clear the query, thumbstick up/down to change the query's share of the budget.\n"
      "While the host is unreachable the last published scene stays drawn under an amber banner.\n"
      "Exit status: 0 when the runtime, --max-frames or SIGINT/SIGTERM ended the session, 1 on an\n"
      "error (no runtime, no headset, a lost session), 2 on a bad command line.",
      "gauss-xr"};
  apps::configure(app);
  std::string host, mode = "progressive";
  app.add_option("--host", host, "the gauss-host to connect to, HOST:PORT")
      ->required()
      ->check(apps::endpoint())
      ->type_name("HOST:PORT");
  app.add_option("--token", o.token, "access token the host requires, or the pairing code it printed");
  app.add_option("--name", o.name, "client name the host logs (and names its dumps after)");
  app.add_option("--budget", o.budget, "M: Gaussian slots of this client")->check(apps::in_range<std::uint32_t>(1, 400000));
  app.add_option("--mode", mode, "publication mode")->check(CLI::IsMember({"progressive", "immediate"}));
  apps::add_on_off(app, "--publication-thread", o.publication_thread,
                   "publish the stream and pack its uploads on a thread of their own, so the display thread only "
                   "hands them over");
  app.add_option("--rho", o.rho, "a query's share of the budget at start")->check(apps::in_range(0.0, 1.0));
  CLI::Option* stage = app.add_flag("--stage", o.stage,
                                    "use the STAGE reference space (floor origin) instead of LOCAL; a captured "
                                    "scene's origin is then placed at eye height (--eye-height) above the floor");
  app.add_option("--eye-height", o.eye_height,
                 "with --stage: metres above the floor where a captured scene's origin (its first camera) goes; "
                 "1.6 for a standing user, about 1.2 for a seated one")
      ->check(apps::in_range(0.0, 3.0))
      ->needs(stage);
  apps::add_up_option(app, o.up,
                      "the scene's up axis (+x -x +y -y +z -z), turned to point up in the room, instead of the "
                      "up the host announces");
  bool no_highlight = false;
  app.add_flag("--no-highlight", no_highlight, "do not tint the objects of the active query");
  app.add_option("--max-frames", o.max_frames, "ask the runtime to end the session after this many frames");
  app.add_option("--out", o.out, "on exit, write summary.json, final_slot_ids.json and the last eyes' cameras here");
  if (auto rc = apps::parse(app, argc, argv)) return rc;
  o.host = *net::parse_endpoint(host);
  o.mode = mode == "immediate" ? PublishMode::Immediate : PublishMode::Progressive;
  o.highlight = !no_highlight;
  return std::nullopt;
}

}  // namespace gauss::xr_app
