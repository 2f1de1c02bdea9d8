// gauss-view's default camera (see default_view.h).
#include "default_view.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

#include "gauss/engine/scene_view.h"
#include "gauss/render/splat_math.h"
#include "options.h"

namespace gauss::view {

FramingLens view_lens(double hfov_deg, std::uint32_t width, std::uint32_t height) {
  FramingLens lens;
  lens.width = width;
  lens.height = height;
  lens.fx = lens.fy = focal_from_hfov(hfov_deg, width);
  // Nearer Gaussians are culled by the renderer whatever the camera's near plane says.
  lens.min_depth = render::kNearCull;
  return lens;
}

std::optional<Framing> default_framing(const ViewSource& source, const glm::dvec3& up, double hfov_deg,
                                       std::uint32_t width, std::uint32_t height, ViewPreset preset) {
  const auto box = source.bounds();
  if (!box) return std::nullopt;
  return frame_preset(box->lo, box->hi, up, view_lens(hfov_deg, width, height), preset, source.up().capture_position);
}

Framing stream_framing(const msg::SceneView& view, const glm::dvec3& up, double hfov_deg, std::uint32_t width,
                       std::uint32_t height, ViewPreset preset) {
  msg::SceneView v = view;
  v.up = glm::vec3(up);
  const glm::dvec3 lo(v.subject_min), hi(v.subject_max), size = hi - lo;
  const bool room = (v.flags & msg::kViewInside) && preset == ViewPreset::Front && glm::length(up - glm::dvec3(0, 1, 0)) < 1e-6 &&
                    size.x > 0.0 && size.z > 0.0;
  if (!room) return frame_scene_view(v, view_lens(hfov_deg, width, height), preset);
  Framing f;
  f.eye = glm::dvec3(lo.x + 0.12 * size.x, lo.y + 0.8 * size.y, lo.z + 0.12 * size.z);
  f.target = glm::dvec3(lo.x + 0.5 * size.x, lo.y + 0.25 * size.y, lo.z + 0.5 * size.z);
  f.up = up;
  f.distance = glm::length(f.target - f.eye);
  f.lo = lo;
  f.hi = hi;
  return f;
}

}  // namespace gauss::view
