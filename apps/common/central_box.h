#pragma once
// The box of a scene's central 96 % per axis (the 2 % and 98 % quantiles of the
// positions): what a viewer frames and an evaluation orbits. Trained scenes carry far
// floaters and background splats that would make the exact bounds useless for either.
#include <algorithm>
#include <cstddef>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/gaussian.h"

namespace gauss::apps {

inline std::pair<glm::dvec3, glm::dvec3> central_box(const std::vector<Gaussian>& gs) {
  glm::dvec3 lo{0.0}, hi{0.0};
  if (gs.empty()) return {lo, hi};
  std::vector<float> axis(gs.size());
  for (int a = 0; a < 3; ++a) {
    for (std::size_t i = 0; i < gs.size(); ++i) axis[i] = gs[i].position[a];
    const std::size_t i_lo = gs.size() * 2 / 100, i_hi = gs.size() - 1 - i_lo;
    std::nth_element(axis.begin(), axis.begin() + static_cast<std::ptrdiff_t>(i_lo), axis.end());
    lo[a] = axis[i_lo];
    std::nth_element(axis.begin(), axis.begin() + static_cast<std::ptrdiff_t>(i_hi), axis.end());
    hi[a] = axis[i_hi];
  }
  return {lo, hi};
}

}  // namespace gauss::apps
