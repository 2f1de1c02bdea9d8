#pragma once
// Indexed triangle mesh with per-vertex colour (the TSDF surface proxy).
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>
#include <glm/gtc/type_precision.hpp>

namespace gauss {

struct TriangleMesh {
  std::vector<glm::vec3> positions;
  std::vector<glm::u8vec3> colors;    // same length as positions
  std::vector<std::uint32_t> indices; // 3 per triangle, counter-clockwise seen from outside
};

}  // namespace gauss
