#include "gauss/engine/scene_view.h"

#include <cmath>

#include <glm/geometric.hpp>

namespace gauss {

namespace {
bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// `v` normalised, or +y where it has no direction (zero, non-finite, or overflowing).
glm::dvec3 unit_or_y(const glm::dvec3& v) {
  const double len = finite(v) ? glm::length(v) : 0.0;
  return len > 0.0 && std::isfinite(len) ? v / len : glm::dvec3(0.0, 1.0, 0.0);
}
}  // namespace

msg::SceneView capture_view(std::span<const Gaussian> gaussians, const glm::dvec3& up,
                            const std::optional<glm::dvec3>& seen_from) {
  msg::SceneView v;
  v.up = glm::vec3(unit_or_y(up));
  const RobustBounds box = robust_bounds(gaussians, BoundsWeighting::Opacity);
  v.subject_min = glm::vec3(box.lo);
  v.subject_max = glm::vec3(box.hi);
  // A box beyond float's range would reach the wire as infinities: the unit box instead.
  if (!finite(glm::dvec3(v.subject_min)) || !finite(glm::dvec3(v.subject_max))) {
    v.subject_min = glm::vec3(-1.0f);
    v.subject_max = glm::vec3(1.0f);
  }
  // Not finite once in float (NaN, or beyond its range): not announced.
  if (seen_from && finite(glm::dvec3(glm::vec3(*seen_from)))) {
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

glm::dvec3 view_up(const msg::SceneView& view) { return unit_or_y(glm::dvec3(view.up)); }

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
