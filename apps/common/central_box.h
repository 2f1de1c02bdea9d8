#pragma once
// The box of a scene's central 96 % per axis (the 2 % and 98 % quantiles of the
// positions, every Gaussian counted alike): the region an evaluation orbits. Trained scenes
// carry far floaters and background splats that would make the exact bounds useless.
// Viewers frame the opacity-weighted box instead (gauss/engine/scene_framing.h), where a
// faint floater weighs nothing; the evaluation keeps the count so its reports stay put.
#include <utility>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/scene_framing.h"

namespace gauss::apps {

// Non-finite centres are left out; none finite: ({0, 0, 0}, {0, 0, 0}).
inline std::pair<glm::dvec3, glm::dvec3> central_box(const std::vector<Gaussian>& gs) {
  const RobustBounds b = robust_bounds(gs, BoundsWeighting::Count);
  if (b.finite == 0) return {glm::dvec3(0.0), glm::dvec3(0.0)};
  return {b.lo, b.hi};
}

}  // namespace gauss::apps
