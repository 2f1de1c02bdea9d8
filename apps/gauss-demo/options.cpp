#include "options.h"

#include <tuple>

#include "gauss_cli.h"

namespace gauss::demo_app {

std::optional<int> parse_options(int argc, char** argv, Options& o) {
  CLI::App app{
      "gauss-demo: the main job on the embedded synthetic scene, end to end in one process. A\n"
      "synthetic room evolves over its epochs (Gaussians appear and converge, a TSDF fuses the\n"
      "surface), then the renderer draws the whole room (room.png), the budgeted client set\n"
      "(room_budget.png) and the same budget with a class query highlighted (room_query.png).",
      "gauss-demo"};
  apps::configure(app);
  std::string size = std::to_string(o.width) + "x" + std::to_string(o.height);
  app.add_option("--variant", o.variant, "synthetic room variant")->check(apps::in_range(0, 3));
  app.add_option("--gaussians", o.gaussians, "Gaussians in the room")->check(apps::at_least<std::size_t>(1));
  app.add_option("--budget", o.budget, "M: the client's Gaussian budget")
      ->check(apps::at_least<std::size_t>(1))
      ->type_name("M");
  app.add_option("--query", o.query, "semantic query: an object class")->type_name("CLASS");
  app.add_option("--rho", o.rho, "share of M reserved for the queried objects")->check(apps::in_range(0.0, 1.0));
  app.add_option("--size", size, "image size")->check(apps::image_size());
  app.add_option("--out", o.out, "folder for the images (created)")->type_name("DIR");
  app.add_option("--device", o.device, "Vulkan device index or name substring (else $GAUSS_DEVICE, else the best)")
      ->type_name("NAME");
  if (auto rc = apps::parse(app, argc, argv)) return rc;
  std::tie(o.width, o.height) = *apps::parse_size(size);
  return std::nullopt;
}

}  // namespace gauss::demo_app
