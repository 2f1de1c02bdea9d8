#pragma once
// Picking the object under a controller's ray among the client's resident Gaussians: the
// nearest Gaussian the ray passes within two standard deviations of (in its own ellipsoid's
// metric), at least half opaque. Its object is the pick; a nearest hit on unlabelled
// content (a wall) picks nothing, so a ray cannot select an object hidden behind it.
#include <cstdint>
#include <optional>

#include <glm/vec3.hpp>

#include "gauss/engine/ids.h"
#include "gauss/engine/slot_table.h"

namespace gauss::client {

struct RayHit {
  ObjectId object{kNoObject};  // kNoObject: the nearest Gaussian hit is unlabelled
  double distance{0.0};        // along the ray to the closest approach, metres
  std::uint32_t slot{0};
};

// `direction` need not be unit length; a zero or non-finite ray hits nothing. Gaussians with
// a degenerate scale (a zero axis) are treated as having a 0.1 mm one there.
std::optional<RayHit> pick(const SlotTable& slots, const glm::dvec3& origin, const glm::dvec3& direction);

}  // namespace gauss::client
