#include "gauss/engine/synthetic_scene.h"

namespace gauss {

Camera SyntheticScene::overview_camera(std::uint32_t width, std::uint32_t height) const {
  // World y is up; the camera follows OpenCV (x right, y down, z forward).
  const glm::dvec3 lo(room_min()), hi(room_max());
  const glm::dvec3 eye(lo.x + 0.12 * (hi.x - lo.x), lo.y + 0.8 * (hi.y - lo.y), lo.z + 0.12 * (hi.z - lo.z));
  const glm::dvec3 target(0.5 * (lo.x + hi.x), lo.y + 0.25 * (hi.y - lo.y), 0.5 * (lo.z + hi.z));
  Camera cam;
  cam.width = width;
  cam.height = height;
  cam.fx = cam.fy = 0.55 * width;
  cam.cx = 0.5 * width;
  cam.cy = 0.5 * height;
  cam.world_to_camera = glm::inverse(opencv_look_at(eye, target, glm::dvec3(0, 1, 0)));
  return cam;
}

}  // namespace gauss
