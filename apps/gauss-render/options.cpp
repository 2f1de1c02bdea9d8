#include "options.h"

#include <array>

#include "gauss_cli.h"

namespace gauss::render_app {

std::optional<int> parse_options(int argc, char** argv, Options& o) {
  CLI::App app{
      "gauss-render: renders one view (or a stereo pair) of a 3DGS scene to PNG, on the GPU\n"
      "(SplatRenderer) or with the CPU reference rasterizer (--reference), and prints the GPU\n"
      "time of every pass.\n"
      "Exit status: 0 written; 1 a file could not be read or written, no usable Vulkan device,\n"
      "or a render error (the message says which); 2 bad arguments.",
      "gauss-render"};
  apps::configure(app);
  app.add_option("--scene", o.scene, "scene file: 3DGS PLY, compressed PLY, .splat, SPZ or SOG (zip or folder)")
      ->required()
      ->check(CLI::ExistingPath)
      ->type_name("SCENE");
  app.add_option("--mesh", o.mesh, "surface mesh drawn under the splats (PLY)")
      ->check(CLI::ExistingFile)
      ->type_name("M.ply");
  app.add_option("--camera", o.camera, "camera (JSON)")->required()->check(CLI::ExistingFile)->type_name("C.json");
  app.add_option("--out", o.out, "image to write (PNG)")->required()->type_name("O.png");
  auto* reference = app.add_flag("--reference", o.reference,
                                 "CPU reference rasterizer (double precision); with --mesh the mesh layer is still "
                                 "rasterized by the GPU mesh pass (the splats are blended on the CPU)");
  auto* stereo = app.add_option("--stereo", o.ipd, "left/right eyes IPD metres apart; writes O_left.png and O_right.png")
                     ->check(apps::in_range(0.0, 1.0))
                     ->type_name("IPD");
  app.add_option("--device", o.device, "Vulkan device index or name substring (else $GAUSS_DEVICE, else the best)")
      ->type_name("NAME");
  std::array<double, 3> clear{o.clear.r, o.clear.g, o.clear.b};
  app.add_option("--clear", clear, "background without a mesh, each in [0, 1]")
      ->delimiter(',')
      ->check(apps::in_range(0.0, 1.0))
      ->type_name("R,G,B")
      ->default_str("0,0,0");
  app.add_option("--frames", o.frames, "GPU: render K times, print every frame's pass times (first = cold)")
      ->check(apps::in_range(1, 1000))
      ->type_name("K")
      ->excludes(reference);
  app.add_option("--threads", o.threads, "--reference: blend threads")->check(apps::in_range(1u, 64u))->type_name("N");
  app.add_option("--order", o.order,
                 "JSON array of the scene's gaussian_ids: load the Gaussians into slots in this order (equal\n"
                 "depths blend in slot order, so this reproduces a client's image exactly; e.g. gauss-view's\n"
                 "final_slot_ids.json)")
      ->check(CLI::ExistingFile);
  app.add_option("--compare", o.compare, "print PSNR and max error of the written image against A.png (mono only)")
      ->check(CLI::ExistingFile)
      ->type_name("A.png")
      ->excludes(stereo);
  if (auto rc = apps::parse(app, argc, argv)) return rc;
  o.stereo = stereo->count() > 0;
  o.clear = glm::dvec3(clear[0], clear[1], clear[2]);
  return std::nullopt;
}

}  // namespace gauss::render_app
