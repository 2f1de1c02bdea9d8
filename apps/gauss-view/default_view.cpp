// gauss-view's default camera (see default_view.h).
#include "default_view.h"

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
  return frame_scene_view(v, view_lens(hfov_deg, width, height), preset);
}

}  // namespace gauss::view
