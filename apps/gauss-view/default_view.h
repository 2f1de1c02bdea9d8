#pragma once
// gauss-view's default camera, shared by the window and headless: the framing
// (gauss/engine/scene_framing.h) of a local scene's robust bounds through the lens of --fov
// at the view's size, upright for the chosen up.
#include <cstdint>
#include <optional>

#include <glm/vec3.hpp>

#include "gauss/engine/messages.h"
#include "gauss/engine/scene_framing.h"
#include "view_source.h"

namespace gauss::view {

// A `width` x `height` pinhole with horizontal field of view `hfov_deg` (fx = fy), the box
// kept beyond the renderer's near cull.
FramingLens view_lens(double hfov_deg, std::uint32_t width, std::uint32_t height);

// The framing of `source`'s bounds for `up` through view_lens(), from the side its capture's
// cameras stood on when it knows (SceneUp::capture_position), or the `preset` view of the
// same box; nullopt when the source has no bounds (a stream).
std::optional<Framing> default_framing(const ViewSource& source, const glm::dvec3& up, double hfov_deg,
                                       std::uint32_t width, std::uint32_t height,
                                       ViewPreset preset = ViewPreset::Front);

// The first view of a stream: frame_scene_view of the view its host announced
// (SceneInfo::view) with `up` instead of the view's (the host's, or --up, or the panel's
// choice), through view_lens().
Framing stream_framing(const msg::SceneView& view, const glm::dvec3& up, double hfov_deg, std::uint32_t width,
                       std::uint32_t height, ViewPreset preset = ViewPreset::Front);

}  // namespace gauss::view
