#pragma once
// Helpers of the splat renderer tests (tests/render/test_splat_*.cpp): cameras, small
// deterministic procedural scenes (the GPU-vs-reference comparison, close_to_reference, is in
// golden.h: golden checks off lavapipe use it too).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/engine/camera.h"
#include "gauss/engine/gaussian.h"
#include "gauss/engine/image_io.h"
#include "gauss/engine/quaternion.h"
#include "gauss/render/image_metrics.h"
#include "gauss/render/reference_rasterizer.h"
#include "gauss/render/splat_renderer.h"
#include "golden.h"
#include "test_data.h"

namespace gauss::test {

// Camera at the origin looking down +z (world = camera frame), horizontal FOV ~60 degrees.
inline Camera forward_camera(std::uint32_t width, std::uint32_t height) {
  Camera c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = 0.866 * width;
  c.cx = width * 0.5;
  c.cy = height * 0.5;
  return c;
}

// Camera at `eye` looking at `target`; `down_hint` is roughly the world direction that
// should point down in the image (OpenCV: image y down).
inline Camera look_at_camera(std::uint32_t width, std::uint32_t height, glm::dvec3 eye, glm::dvec3 target,
                             glm::dvec3 down_hint = {0, 1, 0}) {
  Camera c = forward_camera(width, height);
  const glm::dvec3 z = glm::normalize(target - eye);
  const glm::dvec3 x = glm::normalize(glm::cross(down_hint, z));
  const glm::dvec3 y = glm::cross(z, x);
  glm::dmat4 w2c(1.0);
  for (int i = 0; i < 3; ++i) {
    w2c[i][0] = x[i];
    w2c[i][1] = y[i];
    w2c[i][2] = z[i];
  }
  w2c[3][0] = -glm::dot(x, eye);
  w2c[3][1] = -glm::dot(y, eye);
  w2c[3][2] = -glm::dot(z, eye);
  c.world_to_camera = w2c;
  return c;
}

// Deterministic xorshift (no dependence on the standard library's distributions).
struct Rng {
  std::uint64_t s{88172645463325252ull};
  double next() {
    s ^= s << 13;
    s ^= s >> 7;
    s ^= s << 17;
    return double(s >> 11) * (1.0 / 9007199254740992.0);
  }
  float uniform(double a, double b) { return static_cast<float>(a + (b - a) * next()); }
};

// n Gaussians in a box in front of forward_camera, SH up to `degree`, normalised rotations.
inline std::vector<Gaussian> procedural_scene(std::size_t n, int degree, std::uint64_t seed = 1) {
  Rng rng;
  rng.s ^= seed * 0x9E3779B97F4A7C15ull;
  std::vector<Gaussian> out(n);
  for (auto& g : out) {
    g.position = {rng.uniform(-1.5, 1.5), rng.uniform(-1.0, 1.0), rng.uniform(2.0, 6.0)};
    g.log_scale = {rng.uniform(-4.0, -2.0), rng.uniform(-4.0, -2.0), rng.uniform(-4.0, -2.0)};
    g.rotation = {rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)};
    normalize_quaternion(g.rotation);
    g.opacity_logit = rng.uniform(-2.0, 4.0);
    g.sh_dc = {rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5)};
    for (int k = 0; k < sh_rest_count(degree); ++k)
      g.sh_rest[static_cast<std::size_t>(k)] = {rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2)};
    g.object = ObjectId{static_cast<std::int32_t>(rng.next() * 8)};
  }
  return out;
}

// A camera for a real scene: looking along +z at the scene's median point from
// `distance_scale` median absolute deviations away.
inline Camera scene_camera(const std::vector<Gaussian>& gs, std::uint32_t w, std::uint32_t h, double distance_scale) {
  std::vector<float> xs, ys, zs;
  for (const auto& g : gs) {
    xs.push_back(g.position.x);
    ys.push_back(g.position.y);
    zs.push_back(g.position.z);
  }
  auto median = [](std::vector<float> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return double(v[v.size() / 2]);
  };
  auto spread = [&](std::vector<float> v) {
    const double m = median(v);
    for (auto& x : v) x = std::abs(x - static_cast<float>(m));
    return median(v);
  };
  const glm::dvec3 c(median(xs), median(ys), median(zs));
  const double s = std::max({spread(xs), spread(ys), spread(zs)});
  return look_at_camera(w, h, c + glm::dvec3(0.0, 0.0, -distance_scale * s), c);
}

inline bool all_finite_bytes(const ImageRGBA8& img) {
  return img.pixels.size() == std::size_t{img.width} * img.height * 4;
}

}  // namespace gauss::test
