#include "gauss/engine/scene_view.h"

#include <cmath>

#include <glm/geometric.hpp>

namespace gauss {

namespace {
bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
}  // namespace

msg::SceneView capture_view(std::span<const Gaussian> gaussians, const glm::dvec3& up,
                            const std::optional<glm::dvec3>& seen_from) {
  msg::SceneView v;
  const double len = finite(up) ? glm::length(up) : 0.0;
  v.up = len > 0.0 && std::isfinite(len) ? glm::vec3(up / len) : glm::vec3(0.0f, 1.0f, 0.0f);
  const RobustBounds box = robust_bounds(gaussians, BoundsWeighting::Opacity);
  v.subject_min = glm::vec3(box.lo);
  v.subject_max = glm::vec3(box.hi);
  // The float rounding of a huge box may not keep min <= max per axis only if lo > hi,
  // which robust_bounds never gives; it may overflow to infinity: then the unit box.
  if (!finite(glm::dvec3(v.subject_min)) || !finite(glm::dvec3(v.subject_max))) {
    v.subject_min = glm::vec3(-1.0f);
    v.subject_max = glm::vec3(1.0f);
  }
  if (seen_from && finite(*seen_from) && finite(glm::dvec3(glm::vec3(*seen_from)))) {
    v.flags |= msg::kViewSeenFrom;
    v.seen_from = glm::vec3(*seen_from);
  }
  return v;
}

msg::SceneView room_view(const glm::vec3& lo, const glm::vec3& hi) {
  msg::SceneView v;
  v.subject_min = lo;
  v.subject_max = hi;
  v.flags = msg::kViewInside;
  return v;
}

glm::dvec3 view_up(const msg::SceneView& view) {
  const glm::dvec3 up(view.up);
  const double len = finite(up) ? glm::length(up) : 0.0;
  return len > 0.0 ? up / len : glm::dvec3(0.0, 1.0, 0.0);
}

Framing frame_scene_view(const msg::SceneView& view, const FramingLens& lens, ViewPreset preset) {
  const glm::dvec3 up = view_up(view);
  const glm::dvec3 lo(view.subject_min), hi(view.subject_max), size = hi - lo;
  if ((view.flags & msg::kViewInside) && preset == ViewPreset::Front && up == glm::dvec3(0.0, 1.0, 0.0) &&
      size.x > 0.0 && size.z > 0.0) {
    Framing f;
    f.eye = glm::dvec3(lo.x + 0.12 * size.x, lo.y + 0.8 * size.y, lo.z + 0.12 * size.z);
    f.target = glm::dvec3(lo.x + 0.5 * size.x, lo.y + 0.25 * size.y, lo.z + 0.5 * size.z);
    f.up = up;
    f.distance = glm::length(f.target - f.eye);
    f.lo = lo;
    f.hi = hi;
    return f;
  }
  std::optional<glm::dvec3> seen_from;
  if (view.flags & msg::kViewSeenFrom) seen_from = glm::dvec3(view.seen_from);
  return frame_preset(lo, hi, up, lens, preset, seen_from);
}

}  // namespace gauss
