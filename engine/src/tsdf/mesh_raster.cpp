#include "gauss/engine/mesh_raster.h"

#include <algorithm>
#include <cmath>

namespace gauss {

std::vector<float> render_mesh_depth(const TriangleMesh& mesh, const Camera& cam) {
  const std::size_t w = cam.width, h = cam.height;
  std::vector<float> depth(w * h, 0.0f);
  std::vector<glm::dvec3> screen(mesh.positions.size());  // (u, v, z)
  for (std::size_t k = 0; k < mesh.positions.size(); ++k) {
    const glm::dvec4 t = cam.world_to_camera * glm::dvec4(glm::dvec3(mesh.positions[k]), 1.0);
    screen[k] = {cam.fx * t.x / t.z + cam.cx, cam.fy * t.y / t.z + cam.cy, t.z};
  }
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const glm::dvec3& a = screen[mesh.indices[t]];
    const glm::dvec3& b = screen[mesh.indices[t + 1]];
    const glm::dvec3& c = screen[mesh.indices[t + 2]];
    if (a.z <= cam.near_plane || b.z <= cam.near_plane || c.z <= cam.near_plane) continue;
    const double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (area == 0.0 || !std::isfinite(area)) continue;
    const double minx = std::max(0.0, std::floor(std::min({a.x, b.x, c.x}) - 0.5));
    const double maxx = std::min(double(w) - 1.0, std::ceil(std::max({a.x, b.x, c.x}) - 0.5));
    const double miny = std::max(0.0, std::floor(std::min({a.y, b.y, c.y}) - 0.5));
    const double maxy = std::min(double(h) - 1.0, std::ceil(std::max({a.y, b.y, c.y}) - 0.5));
    for (double y = miny; y <= maxy; ++y)
      for (double x = minx; x <= maxx; ++x) {
        const double px = x + 0.5, py = y + 0.5;
        const double w0 = ((b.x - px) * (c.y - py) - (b.y - py) * (c.x - px)) / area;
        const double w1 = ((c.x - px) * (a.y - py) - (c.y - py) * (a.x - px)) / area;
        const double w2 = 1.0 - w0 - w1;
        if (w0 < 0.0 || w1 < 0.0 || w2 < 0.0) continue;
        const double z = 1.0 / (w0 / a.z + w1 / b.z + w2 / c.z);
        float& d = depth[std::size_t(y) * w + std::size_t(x)];
        if (d == 0.0f || z < d) d = float(z);
      }
  }
  return depth;
}

}  // namespace gauss
