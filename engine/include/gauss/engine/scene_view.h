#pragma once
// The view a host announces with its scene (msg::SceneView) and how a viewer frames it.
//
// A host knows where its scene came from and a client does not: a splat file or a trainer's
// folder is y down unless its cameras say otherwise (scene_up.h), the synthetic room is y up,
// and a real capture's raw bounds hold its floaters. So the host measures once, when it opens
// the scene, and every client frames the same subject the same way a local viewer of the file
// would (scene_framing.h).
#include <optional>
#include <span>

#include <glm/vec3.hpp>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/messages.h"
#include "gauss/engine/scene_framing.h"

namespace gauss {

// A capture's view, seen from outside: `up` normalised (a zero or non-finite one is +y), the
// subject the opacity-weighted robust bounds of `gaussians` (robust_bounds), and `seen_from`
// where the capture's cameras stood, when known and finite.
msg::SceneView capture_view(std::span<const Gaussian> gaussians, const glm::dvec3& up,
                            const std::optional<glm::dvec3>& seen_from = std::nullopt);

// A room's view (the synthetic scene): +y up, standing inside [lo, hi].
msg::SceneView room_view(const glm::vec3& lo, const glm::vec3& hi);

// The up a viewer keeps upright: the view's, normalised in double.
glm::dvec3 view_up(const msg::SceneView& view);

// The first view of a scene as its view says, upright for its up: a room (kViewInside, y up,
// the Front preset) from above a corner inside it (12 % in from the low x and z walls, at
// 80 % of its height) toward a point below its middle (a quarter of its height), as a person
// entering it looks; anything else, and a room's other presets, from outside its subject as a
// local scene's default camera (frame_preset of the subject, up and seen_from). Finite for any
// view the wire accepts.
Framing frame_scene_view(const msg::SceneView& view, const FramingLens& lens, ViewPreset preset = ViewPreset::Front);

}  // namespace gauss
