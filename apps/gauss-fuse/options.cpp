#include "options.h"

#include "gauss_cli.h"

namespace gauss::fuse_app {

std::optional<int> parse_options(int argc, char** argv, Options& o) {
  CLI::App app{
      "gauss-fuse: fuses an RGB-D capture into the TSDF surface (the one gauss-host streams to\n"
      "clients) and writes it as a PLY mesh with vertex colours.\n"
      "The folder's layout is recognised by its files: 3DMatch/SUN3D (camera-intrinsics.txt,\n"
      "frame-N.{depth,color}.png, frame-N.pose.txt, optionally in seq-*/), TUM (rgb.txt, depth.txt,\n"
      "groundtruth.txt) or Replica (results/depthN.png + frameN.jpg, traj.txt, cam_params.json).\n"
      "Prints one summary (frames, volume, vertices, triangles, bounds, times) on stdout.\n"
      "Exit status: 0 written; 1 the folder, a frame, the fusion or the output failed (the\n"
      "message names the frame or file); 2 bad arguments.",
      "gauss-fuse"};
  apps::configure(app);
  app.add_option("--rgbd", o.rgbd, "RGB-D folder to fuse")->required()->check(CLI::ExistingDirectory)->type_name("DIR");
  app.add_option("-o,--out", o.out, "mesh to write (PLY, vertex colours)")->required()->type_name("M.ply");
  app.add_option("--voxel-size", o.voxel_size, "TSDF voxel edge in metres")
      ->check(apps::in_range(0.001f, 1.0f))
      ->type_name("M");
  app.add_option("--truncation", o.truncation, "truncation distance in metres (0: 3 voxels)")
      ->check(apps::in_range(0.0f, 10.0f))
      ->type_name("M");
  app.add_option("--min-depth", o.min_depth, "nearer depths count as missing (metres)")
      ->check(apps::in_range(0.0f, 1000.0f))
      ->type_name("M");
  app.add_option("--max-depth", o.max_depth, "farther depths count as missing (metres)")
      ->check(apps::in_range(0.001f, 1000.0f))
      ->type_name("M");
  app.add_option("--max-blocks", o.max_blocks, "memory bound: TSDF blocks of 8^3 voxels (~6 KiB each)")
      ->check(apps::in_range<std::uint32_t>(1, 50000000))
      ->type_name("N");
  app.add_option("--first", o.first, "first frame to use (index into the folder's frame list)")
      ->check(apps::at_least<std::size_t>(0))
      ->type_name("I");
  app.add_option("--stride", o.stride, "use every K-th frame")->check(apps::at_least<std::size_t>(1))->type_name("K");
  app.add_option("--frames", o.frames, "use at most N frames (0: all)")
      ->check(apps::at_least<std::size_t>(0))
      ->type_name("N");
  app.add_flag("--skip-bad", o.skip_bad,
               "skip a frame that cannot be read or fused (missing pose, wrong image size, ...) with a\n"
               "warning, instead of stopping at it");
  app.add_flag("--ascii", o.ascii, "write an ASCII PLY (default: binary little endian)");
  if (auto rc = apps::parse(app, argc, argv)) return rc;
  if (!(o.max_depth > o.min_depth)) {
    std::fprintf(stderr, "--max-depth: %g is not above --min-depth %g\nRun with --help for more information.\n",
                 double(o.max_depth), double(o.min_depth));
    return apps::kUsageError;
  }
  return std::nullopt;
}

}  // namespace gauss::fuse_app
