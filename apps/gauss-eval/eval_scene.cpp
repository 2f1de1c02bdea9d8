#include "eval_scene.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <glm/gtc/matrix_inverse.hpp>

namespace gauss::eval_app {

Expected<EvalScene> make_scene(const Options& o, int variant) {
  SyntheticSceneConfig sc;
  sc.variant = variant;
  sc.seed = o.seed;
  sc.target_gaussians = o.gaussians;
  sc.epochs = o.epochs;
  sc.surface_chunk = o.surface == "analytic";
  auto synth = SyntheticScene::create(sc);
  if (!synth) return Error{"room " + std::to_string(variant) + ": " + synth.message()};
  EvalScene s;
  s.name = "room" + std::to_string(variant);
  s.variant = variant;
  s.synthetic = std::make_unique<SyntheticScene>(std::move(*synth));
  s.store = std::make_unique<SceneStore>();
  while (!s.synthetic->finished())
    if (auto st = s.synthetic->produce(*s.store); !st) return Error{s.name + ": " + st.message()};
  s.codec.sh_degree = s.store->sh_degree();
  s.codec.box.min = s.synthetic->room_min() - glm::vec3(0.5f);
  s.codec.box.max = s.synthetic->room_max() + glm::vec3(0.5f);
  s.appearance = s.store->size() - s.store->carrier_count();
  // Evenly spread over the trajectory (the centres of `cameras` equal parts), rescaled
  // to the evaluation size.
  const std::vector<Camera>& path = s.synthetic->trajectory();
  for (std::uint32_t k = 0; k < o.cameras; ++k) {
    Camera c = path[static_cast<std::size_t>((k + 0.5) * path.size() / o.cameras)];
    const double sx = double(o.width) / c.width, sy = double(o.height) / c.height;
    c.fx *= sx;
    c.cx *= sx;
    c.fy *= sy;
    c.cy *= sy;
    c.width = o.width;
    c.height = o.height;
    s.cameras.push_back(c);
  }
  return s;
}

Camera look_camera(const glm::dvec3& eye, const glm::dvec3& target, std::uint32_t width, std::uint32_t height) {
  Camera c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = 0.75 * width;
  c.cx = 0.5 * width;
  c.cy = 0.5 * height;
  c.world_to_camera = glm::inverse(opencv_look_at(eye, target, glm::dvec3(0.0, 1.0, 0.0)));
  return c;
}

ObjectViews object_views(const QueryResolution& r, const SyntheticScene& scene, std::uint32_t width,
                         std::uint32_t height) {
  const glm::dvec3 lo(scene.room_min()), hi(scene.room_max());
  const glm::dvec3 centre = 0.5 * (glm::dvec3(r.extent_min) + glm::dvec3(r.extent_max));
  const double size = glm::length(glm::dvec3(r.extent_max) - glm::dvec3(r.extent_min));
  const std::vector<ObjectId> targets = r.ids();  // sorted
  auto inside = [&](glm::dvec3 p) { return glm::clamp(p, lo + 0.25, hi - 0.25); };
  // Target pixels the ground truth shows from `eye` (at 80 x 60: cheap, enough to rank).
  auto visible = [&](const glm::dvec3& eye) {
    const GroundTruthImage gt = scene.render_ground_truth(look_camera(eye, centre, 80, 60));
    return std::count_if(gt.object.begin(), gt.object.end(),
                         [&](ObjectId id) { return std::binary_search(targets.begin(), targets.end(), id); });
  };
  const double dist = std::max(1.0, 1.5 * size);
  glm::dvec3 near_eye = centre;
  std::ptrdiff_t best = -1;
  bool best_full = false;
  for (int k = 0; k < 8; ++k) {
    const double a = k * 0.25 * 3.14159265358979323846;
    glm::dvec3 eye = centre + dist * glm::dvec3(std::cos(a), 0.0, std::sin(a));
    eye.y = std::max(centre.y + 0.4, 1.2);
    eye = inside(eye);
    // A direction the walls cut short (the eye clamped well inside `dist`) would show a
    // close-up of part of the target: taken only when no direction keeps the distance.
    const bool full = glm::length(eye - centre) >= 0.75 * dist;
    const auto n = visible(eye);
    if ((full && !best_full) || (full == best_full && n > best)) {
      best = n;
      best_full = full;
      near_eye = eye;
    }
  }
  glm::dvec3 corners[4];
  std::ptrdiff_t seen[4], most = 0;
  for (int k = 0; k < 4; ++k) {
    corners[k] = inside(glm::dvec3((k & 1) ? hi.x : lo.x, hi.y - 0.4, (k & 2) ? hi.z : lo.z));
    seen[k] = visible(corners[k]);
    most = std::max(most, seen[k]);
  }
  glm::dvec3 far_eye = corners[0];
  double far_dist = -1.0;
  for (int k = 0; k < 4; ++k) {
    const double d = glm::length(corners[k] - centre);
    if (2 * seen[k] >= most && d > far_dist) {
      far_dist = d;
      far_eye = corners[k];
    }
  }
  return {look_camera(near_eye, centre, width, height), look_camera(far_eye, centre, width, height)};
}

std::vector<Gaussian> appearance_gaussians(const SceneStore& store) {
  std::vector<Gaussian> out;
  out.reserve(store.size());
  for (const Gaussian& g : store.gaussians())
    if (!g.carrier) out.push_back(g);
  return out;
}

}  // namespace gauss::eval_app
