// gauss-bench render's capture rows: a real capture placed in front of the box cameras.
#include "bench_capture.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "gauss/engine/ply_gaussian.h"
#include "gauss/engine/scene_up.h"

namespace gauss::bench {

BenchCapture place_capture(const LoadedScene& loaded, const Camera& camera) {
  BenchCapture out;
  out.sh_degree = loaded.scene.cloud.sh_degree;
  const glm::dvec3 centre = loaded.robust.centre();
  const double half_diagonal = 0.5 * glm::length(loaded.robust.hi - loaded.robust.lo);
  const double half_fov_tan = std::min(0.5 * camera.width / camera.fx, 0.5 * camera.height / camera.fy);
  const double distance = std::max(half_diagonal, 1e-3) / half_fov_tan;
  const glm::dvec3 up = loaded.up.up;
  const bool turn = up.y < -0.999, as_is = up.y > 0.999;
  out.gaussians = loaded.scene.cloud.gaussians;
  for (Gaussian& g : out.gaussians) g.position = glm::vec3(glm::dvec3(g.position) - centre);
  if (turn) half_turn_about_x(out.gaussians);
  for (Gaussian& g : out.gaussians) g.position = glm::vec3(glm::dvec3(g.position) + glm::dvec3(0.0, 0.0, -distance));
  const std::string up_text = turn ? "-y turned to +y" : as_is ? "+y" : "left as stored (" + loaded.up.detail + ")";
  char text[160];
  std::snprintf(text, sizeof text, "%zu Gaussians, SH %d, robust box centred at z = -%.3g (half diagonal %.3g), up ",
                out.gaussians.size(), out.sh_degree, distance, half_diagonal);
  out.placement = text + up_text;
  return out;
}

Status write_peer_capture_ply(const std::filesystem::path& path, std::span<const Gaussian> gaussians) {
  GaussianCloud cloud;
  cloud.sh_degree = 3;  // entries past the capture's degree are zero (Gaussian::sh_rest)
  cloud.gaussians.assign(gaussians.begin(), gaussians.end());
  return write_gaussian_ply(path, cloud, {.write_normals = true});
}

}  // namespace gauss::bench
