// Reference preprocess: one Gaussian -> one splat (splat_math.h steps 1-11), in double.
#include <algorithm>
#include <cmath>
#include <string>

#include <glm/mat3x3.hpp>
#include <glm/geometric.hpp>

#include "gauss/render/reference_rasterizer.h"

namespace gauss::render {
namespace {

// Standard rotation matrix of the unit quaternion (w, x, y, z), stored column-major.
glm::dmat3 rotation_matrix(const glm::vec4& q) {
  const double r = q[0], x = q[1], y = q[2], z = q[3];
  glm::dmat3 m;
  m[0] = glm::dvec3(1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + r * z), 2.0 * (x * z - r * y));
  m[1] = glm::dvec3(2.0 * (x * y - r * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z + r * x));
  m[2] = glm::dvec3(2.0 * (x * z + r * y), 2.0 * (y * z - r * x), 1.0 - 2.0 * (x * x + y * y));
  return m;
}

// getRect's clamp, applied in floating point so a huge centre never overflows an int.
std::uint32_t tile_bound(double x, std::uint32_t grid) {
  const double t = std::trunc(x / kTileSize);
  return static_cast<std::uint32_t>(std::min(double(grid), std::max(0.0, t)));
}

}  // namespace

glm::dvec3 eval_sh(const Gaussian& g, int degree, const glm::dvec3& dir) {
  auto sh = [&g](int k) -> glm::dvec3 { return k == 0 ? glm::dvec3(g.sh_dc) : glm::dvec3(g.sh_rest[k - 1]); };
  glm::dvec3 result = kShC0 * sh(0);
  if (degree < 1) return result;
  const double x = dir.x, y = dir.y, z = dir.z;
  result = result - kShC1 * y * sh(1) + kShC1 * z * sh(2) - kShC1 * x * sh(3);
  if (degree < 2) return result;
  const double xx = x * x, yy = y * y, zz = z * z, xy = x * y, yz = y * z, xz = x * z;
  result = result + kShC2[0] * xy * sh(4) + kShC2[1] * yz * sh(5) + kShC2[2] * (2.0 * zz - xx - yy) * sh(6) +
           kShC2[3] * xz * sh(7) + kShC2[4] * (xx - yy) * sh(8);
  if (degree < 3) return result;
  result = result + kShC3[0] * y * (3.0 * xx - yy) * sh(9) + kShC3[1] * xy * z * sh(10) +
           kShC3[2] * y * (4.0 * zz - xx - yy) * sh(11) + kShC3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy) * sh(12) +
           kShC3[4] * x * (4.0 * zz - xx - yy) * sh(13) + kShC3[5] * z * (xx - yy) * sh(14) +
           kShC3[6] * x * (xx - 3.0 * yy) * sh(15);
  return result;
}

bool gaussian_is_finite(const Gaussian& g, int degree) {
  if (!finite3(g.position) || !finite3(g.log_scale) || !finite3(g.sh_dc) || !std::isfinite(g.opacity_logit)) return false;
  for (int i = 0; i < 4; ++i)
    if (!std::isfinite(g.rotation[i])) return false;
  const int rest = sh_rest_count(std::clamp(degree, 0, kMaxShDegree));
  for (int k = 0; k < rest; ++k)
    if (!finite3(g.sh_rest[static_cast<std::size_t>(k)])) return false;
  return true;
}

Status validate_camera(const Camera& camera) {
  constexpr std::uint32_t kMaxSide = 16384;
  if (camera.width == 0 || camera.height == 0 || camera.width > kMaxSide || camera.height > kMaxSide)
    return Error{"camera: size " + std::to_string(camera.width) + "x" + std::to_string(camera.height) +
                 " outside 1.." + std::to_string(kMaxSide)};
  if (!(std::isfinite(camera.fx) && camera.fx > 0.0) || !(std::isfinite(camera.fy) && camera.fy > 0.0))
    return Error{"camera: fx and fy must be finite and positive"};
  if (!std::isfinite(camera.cx) || !std::isfinite(camera.cy)) return Error{"camera: cx and cy must be finite"};
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(camera.world_to_camera[c][r]))
        return Error{"camera: world_to_camera has a non-finite entry (row " + std::to_string(r) + ", column " +
                     std::to_string(c) + ")"};
  return Ok{};
}

ProjectedSplat project_splat(const Gaussian& g, std::uint32_t slot, int sh_degree, const Camera& camera,
                             bool highlighted, EditTintState edit) {
  ProjectedSplat s;
  s.slot = slot;
  if (!gaussian_is_finite(g, sh_degree)) {
    s.cull = SplatCull::NonFinite;
    return s;
  }

  // Step 11 (tints) only needs colour/opacity, but a faded-out removal is decided first so
  // that it counts as "not drawn" whatever the geometry.
  if (edit.kind == EditTintKind::Removed && edit.age >= kRemovedFadeFrames) {
    s.cull = SplatCull::Removed;
    return s;
  }

  // 1. View space.
  const glm::dmat3 W(camera.world_to_camera);
  const glm::dvec3 w(camera.world_to_camera[3]);
  const glm::dvec3 p(g.position);
  const glm::dvec3 t = W * p + w;
  s.view = t;
  s.depth_key = static_cast<float>(t.z);

  // 2. Near cull.
  if (t.z <= kNearCull) {
    s.cull = SplatCull::Near;
    return s;
  }

  // 3. 3D covariance.
  const glm::dmat3 R = rotation_matrix(g.rotation);
  const glm::dvec3 scale(std::exp(double(g.log_scale.x)), std::exp(double(g.log_scale.y)),
                         std::exp(double(g.log_scale.z)));
  glm::dmat3 M = R;  // M = R S (columns scaled)
  M[0] *= scale.x;
  M[1] *= scale.y;
  M[2] *= scale.z;
  const glm::dmat3 sigma = M * glm::transpose(M);

  // 4. EWA with the frustum clamp (the clamp feeds J only).
  const double lim_x = kFrustumClamp * double(camera.width) / (2.0 * camera.fx);
  const double lim_y = kFrustumClamp * double(camera.height) / (2.0 * camera.fy);
  const double tx = std::clamp(t.x / t.z, -lim_x, lim_x) * t.z;
  const double ty = std::clamp(t.y / t.z, -lim_y, lim_y) * t.z;
  const double tz2 = t.z * t.z;
  // Rows of J W: J is 2x3, so (J W) row r = sum_k J[r][k] * (row k of W).
  const glm::dmat3 Wt = glm::transpose(W);  // Wt[k] = row k of W
  const glm::dvec3 jw0 = (camera.fx / t.z) * Wt[0] + (-camera.fx * tx / tz2) * Wt[2];
  const glm::dvec3 jw1 = (camera.fy / t.z) * Wt[1] + (-camera.fy * ty / tz2) * Wt[2];
  const double a = glm::dot(jw0, sigma * jw0) + kDilation;
  const double b = glm::dot(jw0, sigma * jw1);
  const double c = glm::dot(jw1, sigma * jw1) + kDilation;
  s.cov2d = glm::dvec3(a, b, c);

  // 5. Conic.
  const double det = a * c - b * b;
  if (det == 0.0 || !std::isfinite(det)) {
    s.cull = SplatCull::Degenerate;
    return s;
  }
  s.conic = glm::dvec3(c / det, -b / det, a / det);

  // 6. Radius.
  const double mid = 0.5 * (a + c);
  const double root = std::sqrt(std::max(kLambdaFloor, mid * mid - det));
  const double l1 = mid + root, l2 = mid - root;
  s.radius = std::ceil(kSigmaExtent * std::sqrt(std::max(l1, l2)));
  if (!std::isfinite(s.radius)) {
    s.cull = SplatCull::Degenerate;
    return s;
  }

  // 7. Centre (unclamped projection).
  s.u = camera.fx * t.x / t.z + camera.cx;
  s.v = camera.fy * t.y / t.z + camera.cy;

  // 8. Tile rectangle.
  const std::uint32_t gx = tile_count(camera.width), gy = tile_count(camera.height);
  s.tile_min_x = tile_bound(s.u - s.radius, gx);
  s.tile_max_x = tile_bound(s.u + s.radius + (kTileSize - 1), gx);
  s.tile_min_y = tile_bound(s.v - s.radius, gy);
  s.tile_max_y = tile_bound(s.v + s.radius + (kTileSize - 1), gy);
  if (s.radius == 0.0 || s.tile_max_x <= s.tile_min_x || s.tile_max_y <= s.tile_min_y) {
    s.cull = SplatCull::OffScreen;
    return s;
  }

  // 9. Colour from SH in the direction from the camera centre (c = -W^T w).
  const glm::dvec3 centre = -(Wt * w);
  const glm::dvec3 dir = glm::normalize(p - centre);
  s.colour = glm::max(eval_sh(g, sh_degree, dir) + 0.5, glm::dvec3(0.0));

  // 10-11. Opacity and tints.
  s.opacity = sigmoid(double(g.opacity_logit));
  apply_tints(highlighted, edit, s.colour, s.opacity);
  s.cull = SplatCull::Visible;
  return s;
}

}  // namespace gauss::render
