// gauss-bench render's capture rows: a real capture placed in front of the box cameras.
#include "bench_capture.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include "gauss/engine/ply_gaussian.h"

namespace gauss::bench {

namespace {

// The sign of each SH rest coefficient (3DGS order, coefficients 1..15) under the half turn
// about x, (x, y, z) -> (x, -y, -z): -1 where the basis function is odd in y and z together.
// Degree 1: y, z, x. Degree 2: xy, yz, 3z^2 - 1, xz, x^2 - y^2. Degree 3: y(3x^2 - y^2), xyz,
// y(4z^2 - x^2 - y^2), z(2z^2 - 3x^2 - 3y^2), x(4z^2 - x^2 - y^2), z(x^2 - y^2), x(x^2 - 3y^2).
constexpr std::array<float, 15> kHalfTurnXSigns = {-1, -1, 1, -1, 1, 1, -1, 1, -1, 1, -1, -1, 1, -1, 1};

// q' = (0, 1, 0, 0) * q: the half turn about x applied after q (w, x, y, z order).
glm::vec4 half_turn_x(const glm::vec4& q) { return {-q[1], q[0], -q[3], q[2]}; }

}  // namespace

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
  for (Gaussian& g : out.gaussians) {
    glm::dvec3 p = glm::dvec3(g.position) - centre;
    if (turn) {
      p = {p.x, -p.y, -p.z};
      g.rotation = half_turn_x(g.rotation);
      for (std::size_t k = 0; k < kHalfTurnXSigns.size(); ++k) g.sh_rest[k] *= kHalfTurnXSigns[k];
    }
    g.position = glm::vec3(p + glm::dvec3(0.0, 0.0, -distance));
  }
  const std::string up_text = turn ? "-y turned to +y" : as_is ? "+y" : "left as stored (" + loaded.up.detail + ")";
  char text[160];
  std::snprintf(text, sizeof text, "%zu Gaussians, SH %d, robust box centred at z = -%.3g (half diagonal %.3g), up ",
                out.gaussians.size(), out.sh_degree, distance, half_diagonal);
  out.placement = text + up_text;
  return out;
}

Status write_peer_capture_ply(const std::filesystem::path& path, const BenchCapture& capture) {
  GaussianCloud cloud;
  cloud.sh_degree = 3;  // entries past the capture's degree are zero (Gaussian::sh_rest)
  cloud.gaussians = capture.gaussians;
  return write_gaussian_ply(path, cloud, {.write_normals = true});
}

}  // namespace gauss::bench
