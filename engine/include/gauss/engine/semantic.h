#pragma once
// Persistent semantic objects as the host tracks them.
#include <cstdint>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/ids.h"

namespace gauss {

struct SemanticObject {
  ObjectId id{kNoObject};
  std::string label;                 // class label, e.g. "chair" (queries match case-insensitively)
  std::vector<GaussianId> members;   // appearance Gaussians of this instance (carriers excluded)
  glm::vec3 centroid{0.0f};
  glm::vec3 extent_min{0.0f};        // axis-aligned bounds of the members
  glm::vec3 extent_max{0.0f};
  float quality{0.0f};               // observation quality in [0, 1] (e.g. mean support, confidence)
};

}  // namespace gauss
