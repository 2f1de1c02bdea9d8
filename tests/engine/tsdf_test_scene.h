#pragma once
// An analytic scene for TSDF tests: the inside of a box-shaped room with a sphere in
// it, rendered to exact depth images from look-at cameras.
#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>

#include "gauss/engine/camera.h"
#include "gauss/engine/tsdf.h"

namespace gauss::test {

struct AnalyticRoom {
  glm::dvec3 room_min{-2.0, -1.5, -2.0}, room_max{2.0, 1.5, 2.0};
  glm::dvec3 sphere_centre{0.3, -0.2, 0.4};
  double sphere_radius{0.5};

  // Distance from p (inside the room) to the nearest analytic surface.
  double distance(const glm::dvec3& p) const {
    double d = std::abs(glm::length(p - sphere_centre) - sphere_radius);
    for (int a = 0; a < 3; ++a) d = std::min({d, std::abs(p[a] - room_min[a]), std::abs(room_max[a] - p[a])});
    return d;
  }

  // Ray parameter of the first hit from o along unit d (o inside the room).
  double cast(const glm::dvec3& o, const glm::dvec3& d) const {
    double t = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
      if (d[a] > 0) t = std::min(t, (room_max[a] - o[a]) / d[a]);
      if (d[a] < 0) t = std::min(t, (room_min[a] - o[a]) / d[a]);
    }
    const glm::dvec3 oc = o - sphere_centre;
    const double b = glm::dot(oc, d), c = glm::dot(oc, oc) - sphere_radius * sphere_radius;
    const double disc = b * b - c;
    if (disc >= 0) {
      const double t0 = -b - std::sqrt(disc);
      if (t0 > 0) t = std::min(t, t0);
    }
    return t;
  }

  RgbdFrame frame(const glm::dvec3& eye, const glm::dvec3& target, std::uint32_t w, std::uint32_t h,
                  Epoch epoch) const {
    RgbdFrame f;
    f.name = "analytic";
    f.width = w;
    f.height = h;
    f.fx = f.fy = 0.8 * w;
    f.cx = w / 2.0;
    f.cy = h / 2.0;
    f.camera_to_world = opencv_look_at(eye, target, glm::dvec3(0, 1, 0));
    f.epoch = epoch;
    f.depth.resize(std::size_t(w) * h);
    const glm::dmat3 R(f.camera_to_world);
    for (std::uint32_t i = 0; i < h; ++i)
      for (std::uint32_t j = 0; j < w; ++j) {
        const glm::dvec3 rc((j + 0.5 - f.cx) / f.fx, (i + 0.5 - f.cy) / f.fy, 1.0);
        const glm::dvec3 dir = glm::normalize(R * rc);
        const double t = cast(eye, dir);
        f.depth[std::size_t(i) * w + j] = float(t / glm::length(rc));  // view depth (camera z)
      }
    return f;
  }
};

}  // namespace gauss::test
