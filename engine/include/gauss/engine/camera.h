#pragma once
// Pinhole camera in the OpenCV/COLMAP convention: x right, y down, z forward.
// Pixel (row i, column j) samples the image plane at (j + 0.5, i + 0.5) with
// u = fx * x / z + cx, v = fy * y / z + cy.
#include <cstdint>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

namespace gauss {

struct Camera {
  std::uint32_t width{0};
  std::uint32_t height{0};
  double fx{0.0}, fy{0.0}, cx{0.0}, cy{0.0};
  glm::dmat4 world_to_camera{1.0};  // rigid transform, column-major (GLM); files store it row-major
  double near_plane{0.2};           // the 3DGS reference culls at view depth <= 0.2
  double far_plane{1000.0};
};

// Camera-to-world transform of an OpenCV camera at `eye` looking at `target`, with
// image-up as close to `world_up` as the view direction allows (x right, y down, z
// forward). `target` must differ from `eye` and not lie straight along `world_up`.
glm::dmat4 opencv_look_at(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& world_up);

// `c` rendering a width x height image of the same view: focal lengths and principal point
// scaled per axis (pixel centres sit at +0.5 in both sizes, so cx scales like fx).
Camera resized_camera(const Camera& c, std::uint32_t width, std::uint32_t height);

}  // namespace gauss
