#include "gauss/engine/camera.h"

#include <glm/geometric.hpp>

namespace gauss {

glm::dmat4 opencv_look_at(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& world_up) {
  const glm::dvec3 forward = glm::normalize(target - eye);
  const glm::dvec3 right = glm::normalize(glm::cross(forward, world_up));
  const glm::dvec3 down = glm::cross(forward, right);
  glm::dmat4 T(1.0);
  T[0] = glm::dvec4(right, 0.0);
  T[1] = glm::dvec4(down, 0.0);
  T[2] = glm::dvec4(forward, 0.0);
  T[3] = glm::dvec4(eye, 1.0);
  return T;
}

Camera resized_camera(const Camera& c, std::uint32_t width, std::uint32_t height) {
  Camera out = c;
  const double sx = double(width) / c.width, sy = double(height) / c.height;
  out.fx *= sx;
  out.cx *= sx;
  out.fy *= sy;
  out.cy *= sy;
  out.width = width;
  out.height = height;
  return out;
}

}  // namespace gauss
