#include "options.h"

#include <filesystem>
#include <map>
#include <system_error>

#include "endpoint_option.h"
#include "gauss_cli.h"

namespace gauss::host_app {

namespace {

const std::string kSyntheticPrefix = "synthetic:";

// "synthetic:0" .. "synthetic:3" -> the variant, else std::nullopt.
std::optional<int> parse_synthetic(const std::string& s) {
  int v = -1;
  if (s.rfind(kSyntheticPrefix, 0) != 0 || !CLI::detail::lexical_cast(s.substr(kSyntheticPrefix.size()), v) || v < 0 ||
      v > 3)
    return std::nullopt;
  return v;
}

// A --scene value: synthetic:0..3, or an existing file or folder.
std::string check_scene(const std::string& in) {
  if (in.rfind(kSyntheticPrefix, 0) == 0)
    return parse_synthetic(in) ? std::string{} : "Value " + in + " is not synthetic:0..3";
  std::error_code ec;
  if (!std::filesystem::exists(in, ec)) return "Scene " + in + " does not exist (nor is it synthetic:0..3)";
  return {};
}

}  // namespace

std::optional<int> parse_options(int argc, char** argv, Options& o) {
  CLI::App app{
      "gauss-host: streams an evolving scene to VR/desktop clients over ENet.\n"
      "Binds 127.0.0.1 by default: other machines reach the host only with an explicit --bind.\n"
      "New epochs come every --epoch-period seconds: the synthetic trajectory until it ends, a\n"
      "snapshot folder whenever a new snapshot appears (followed live). The host keeps serving the\n"
      "latest epoch until --duration passes or SIGINT/SIGTERM. Once a second it prints the epoch,\n"
      "clients, edits/s and bytes/s; a summary on exit.",
      "gauss-host"};
  apps::configure(app);
  std::string bind = net::to_string(o.bind);
  std::string scene = "synthetic:" + std::to_string(o.variant);
  app.add_option("--bind", bind, "address to listen on, HOST:PORT, HOST or :PORT (port 0: any free port)")
      ->check(apps::endpoint())
      ->type_name("HOST:PORT");
  auto* token = app.add_option("--token", o.token,
                               "access token clients must prove (CPace: it never crosses the wire, and a guess "
                               "can only be tried against the live host, at most 10 per second); 'auto' generates "
                               "a random one and a short pairing code accepted instead, and prints both. Shorter "
                               "than 8 characters draws a warning");
  app.add_flag("--encrypt", o.encrypt,
               "seal the stream after the handshake (XChaCha20-Poly1305, keys from the handshake's key exchange: "
               "a recording stays sealed even if the token leaks later): for private scenes")
      ->needs(token);
  app.add_option("--scene", scene,
                 "scene to stream: synthetic:VARIANT (0..3), a scene file (3DGS PLY, compressed PLY, .splat, "
                 "SPZ, SOG), a folder of snapshots followed live, or an RGB-D capture (3DMatch/SUN3D, TUM or "
                 "Replica layout: its frames replayed as epochs, Gaussians seeded from their pixels, the surface "
                 "fused from their depth)")
      ->check(CLI::Validator([](std::string& in) { return check_scene(in); }, ""))
      ->type_name("SOURCE");
  app.add_option("--labels", o.labels, "per-Gaussian object ids (one integer per line, 0 = none)")
      ->check(CLI::ExistingFile)
      ->type_name("FILE");
  app.add_option("--objects", o.objects, "objects JSON: the class label of each object id")
      ->check(CLI::ExistingFile)
      ->type_name("FILE");
  app.add_option("--rgbd", o.rgbd, "fuse this RGB-D capture (3DMatch/SUN3D, TUM or Replica layout) into the surface")
      ->check(CLI::ExistingDirectory)
      ->type_name("DIR");
  app.add_option("--rgbd-stride", o.rgbd_stride,
                 "an RGB-D capture as the scene: one Gaussian per STRIDE x STRIDE pixel block with depth that "
                 "the earlier frames' Gaussians do not already show")
      ->check(apps::in_range(1u, 64u));
  apps::add_up_option(app, o.up,
                      "a scene file's or folder's up axis, announced to clients so that they show it upright: +x -x "
                      "+y -y +z -z (default: the trainer's cameras.json beside it gives the capture's up, else -y, "
                      "the 3DGS/COLMAP convention; an RGB-D capture: its cameras' up; synthetic: +y)");
  app.add_option("--mesh", o.mesh, "a fixed surface mesh (PLY) instead of the meshes beside the snapshots")
      ->check(CLI::ExistingFile)
      ->type_name("FILE");
  app.add_option("--max-budget", o.max_budget, "largest budget M a client is granted (0: the engine's maximum)");
  app.add_option("--rho", o.rho, "a query's share of the budget when the client leaves it to the host")
      ->check(apps::in_range(0.0, 1.0));
  app.add_option("--min-opacity", o.min_opacity, "eligibility: Gaussians less opaque are never sent (0: off)")
      ->check(apps::in_range(0.0f, 1.0f));
  app.add_option("--max-scale", o.max_scale, "eligibility: Gaussians larger (metres) are never sent (0: off)")
      ->check(apps::at_least(0.0f));
  app.add_option("--min-support", o.min_support, "eligibility: Gaussians seen fewer times are never sent (0: off)");
  app.add_option("--gaussians", o.gaussians, "Gaussians in the synthetic scene")->check(apps::at_least<std::size_t>(1));
  app.add_option("--epochs", o.epochs, "epochs of the synthetic trajectory")->check(apps::at_least(1));
  app.add_option("--epoch-period", o.epoch_period_s, "replay rate: seconds between epochs (synthetic, folder)")->check(apps::at_least(0.0));
  app.add_option("--settle", o.settle_s,
                 "a snapshot that fails to load but was written less than this many seconds ago is waited for "
                 "(a trainer may still be writing it), not skipped")
      ->check(apps::at_least(0.0));
  app.add_option("--seed", o.seed, "seed of the synthetic scene");
  app.add_option("--max-clients", o.max_clients, "clients served at once")->check(apps::at_least<std::size_t>(1));
  app.add_option("--max-clients-per-address", o.max_clients_per_address,
                 "clients served at once from one IP address (clients on this machine share 127.0.0.1)")
      ->check(apps::at_least<std::size_t>(1));
  app.add_option("--session-open-rate", o.session_open_rate_hz,
                 "sessions one IP address may open per second, after a burst of 8 (each costs the host a scene "
                 "description, the surface and a resync; many clients restarting on this machine raise it)")
      ->check(apps::in_range(0.01, 1000.0));
  app.add_option("--handshake-timeout", o.handshake_timeout_s,
                 "seconds a connection may take to complete ENet's handshake, and again to send its Hello (and "
                 "proof); slower ones are dropped")
      ->check(apps::in_range(0.1, 60.0));
  app.add_option("--duration", o.duration_s, "seconds to run (0: until SIGINT/SIGTERM)")->check(apps::at_least(0.0));
  app.add_option("--surface-voxel", o.surface_voxel,
                 "TSDF voxel size in metres for the fused surface (synthetic, --rgbd, a capture as the scene; 0: none "
                 "for synthetic and a capture)")
      ->check(apps::at_least(0.0));
  app.add_option("--events", o.events_path, "write every session's stage events to FILE as JSON lines")
      ->type_name("FILE");
  app.add_option("--sessions", o.sessions_path,
                 "write where the host listens and every client that joins and leaves (name, Gaussians sent, "
                 "checksum) to FILE as JSON lines, for scripts")
      ->type_name("FILE");
  app.add_option("--dump-sent", o.dump_sent_dir,
                 "write what each client was sent when its session ends (see below)")
      ->type_name("DIR");
  app.add_option("--lod", o.lod,
                 "level of detail: 'on' (default) sends what a client's budget cannot hold in detail as a coarse cut "
                 "through a merge hierarchy (no black holes; one hierarchy for all clients, about 0.6 KB per "
                 "Gaussian; where the machine lacks the memory, the best Gaussians with one logged line), 'off' "
                 "sends the best Gaussians only")
      ->transform(CLI::Transformer(std::map<std::string, bool>{{"on", true}, {"off", false}}))
      ->type_name("on|off")
      ->default_str(o.lod ? "on" : "off");
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
  if (auto v = parse_synthetic(scene))
    o.variant = *v;
  else
    o.scene_path = scene;
  return std::nullopt;
}

}  // namespace gauss::host_app
