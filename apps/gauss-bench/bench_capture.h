#pragma once
// A real capture for gauss-bench render's capture@WxH rows (--capture FILE): the scene file
// placed in front of the box cameras (the camera at the origin looking down -z, y up, which
// the peer's camera is too), so that ours and the peer render the same view of it.
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "gauss/engine/camera.h"
#include "gauss/engine/gaussian.h"
#include "gauss/engine/result.h"
#include "gauss/engine/scene_load.h"

namespace gauss::bench {

struct BenchCapture {
  std::vector<Gaussian> gaussians;  // in the box cameras' world
  int sh_degree{0};
  std::string placement;            // how it was placed, for the output
};

// Places `loaded` in front of `camera` (a box camera): its robust box's centre on the -z
// axis, at the distance where the box's half diagonal fills the smaller half field of view,
// and its up (load_scene_file's: cameras.json, else 3DGS's y down) turned to +y when that
// up is -y (a half turn about x: positions, rotations and the SH coefficients' signs, which
// is exact) or +y; any other up is left as stored and said so.
BenchCapture place_capture(const LoadedScene& loaded, const Camera& camera);

// Placed Gaussians as the peer reads them: a binary PLY with normals and all 45 SH rest
// coefficients (zero past the capture's degree), the one layout its loader takes.
Status write_peer_capture_ply(const std::filesystem::path& path, std::span<const Gaussian> gaussians);

}  // namespace gauss::bench
