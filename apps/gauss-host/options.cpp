#include "options.h"

#include "endpoint_option.h"
#include "gauss_cli.h"

namespace gauss::host_app {

namespace {

// "synthetic:0" .. "synthetic:3" -> the variant, else std::nullopt.
std::optional<int> parse_scene(const std::string& s) {
  const std::string prefix = "synthetic:";
  int v = -1;
  if (s.rfind(prefix, 0) != 0 || !CLI::detail::lexical_cast(s.substr(prefix.size()), v) || v < 0 || v > 3)
    return std::nullopt;
  return v;
}

}  // namespace

std::optional<int> parse_options(int argc, char** argv, Options& o) {
  CLI::App app{
      "gauss-host: streams an evolving synthetic scene to VR/desktop clients over ENet.\n"
      "Binds 127.0.0.1 by default: other machines reach the host only with an explicit --bind.\n"
      "New epochs are produced every --epoch-period seconds until the trajectory ends; the host\n"
      "then keeps serving the final scene until --duration passes or SIGINT/SIGTERM. Once a\n"
      "second it prints clients, epoch and wire throughput.",
      "gauss-host"};
  apps::configure(app);
  std::string bind = net::to_string(o.bind);
  std::string scene = "synthetic:" + std::to_string(o.variant);
  app.add_option("--bind", bind, "address to listen on, HOST:PORT, HOST or :PORT (port 0: any free port)")
      ->check(apps::endpoint())
      ->type_name("HOST:PORT");
  app.add_option("--token", o.token, "access token clients must present (default: none required)");
  app.add_option("--scene", scene, "scene to stream: synthetic:VARIANT, VARIANT in 0..3")
      ->check(CLI::Validator(
          [](std::string& in) -> std::string {
            return parse_scene(in) ? std::string{} : "Value " + in + " is not synthetic:0..3";
          },
          ""))
      ->type_name("synthetic:V");
  app.add_option("--gaussians", o.gaussians, "Gaussians in the synthetic scene")->check(apps::at_least<std::size_t>(1));
  app.add_option("--epochs", o.epochs, "epochs of the synthetic trajectory")->check(apps::at_least(1));
  app.add_option("--epoch-period", o.epoch_period_s, "seconds between epochs")->check(apps::at_least(0.0));
  app.add_option("--seed", o.seed, "seed of the synthetic scene");
  app.add_option("--max-clients", o.max_clients, "clients served at once")->check(apps::at_least<std::size_t>(1));
  app.add_option("--duration", o.duration_s, "seconds to run (0: until SIGINT/SIGTERM)")->check(apps::at_least(0.0));
  app.add_option("--surface-voxel", o.surface_voxel, "TSDF voxel size in metres for the surface (0: no surface)")
      ->check(apps::at_least(0.0));
  app.add_option("--events", o.events_path, "write every session's stage events to FILE as JSON lines")
      ->type_name("FILE");
  app.add_option("--dump-sent", o.dump_sent_dir,
                 "write what each client was sent when its session ends (see below)")
      ->type_name("DIR");
  app.add_flag("--quiet", o.quiet, "no once-a-second status line");
  app.footer(
      "--dump-sent DIR: when a client's session ends (it disconnects, or the host exits), writes\n"
      "  DIR/NAME.ply       the Gaussians the host had sent it, each as the client decodes it\n"
      "                     (quantised and dequantised), with gaussian_id, object_id, support;\n"
      "  DIR/NAME.mesh.ply  the scene's surface mesh at that time, when it has one.\n"
      "  NAME is the client's Hello name with every character other than a letter, digit, '-'\n"
      "  or '_' replaced by '_' (client-ID when empty). Clients sharing a name write the same\n"
      "  files: the session that ends last wins. A failed dump is reported; the host goes on.");
  if (auto rc = apps::parse(app, argc, argv)) return rc;
  o.bind = net::parse_endpoint(bind).value();
  o.variant = *parse_scene(scene);
  return std::nullopt;
}

}  // namespace gauss::host_app
