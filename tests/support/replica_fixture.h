#pragma once
// A small hand-made RGB-D capture in the Replica layout (results/frameNNNNNN.jpg +
// results/depthNNNNNN.png, traj.txt, cam_params.json): a few 64x48 cameras looking at one
// known tilted plane, with exact depth (up to the 1/6553.5 m depth unit) and a uniform
// colour, so a fused surface can be checked against the plane. Written into a test's
// folder by the test itself; nothing is committed.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/gtc/type_precision.hpp>
#include <glm/vec3.hpp>

#include "gauss/engine/image_io.h"

namespace gauss::test {

struct ReplicaPlane {
  std::filesystem::path folder;
  std::uint32_t width{64}, height{48};
  double fx{40.0}, fy{40.0}, cx{31.5}, cy{23.5};
  double depth_scale{6553.5};        // NICE-SLAM's Replica depth unit: 1/6553.5 m (10 m max)
  glm::dvec3 normal{0.0};            // unit, facing the cameras
  double offset{0.0};                // plane: dot(normal, x) = offset
  glm::u8vec3 colour{200, 120, 60};
  std::vector<glm::dmat4> poses;     // camera-to-world, OpenCV axes (x right, y down, z forward)
  glm::dvec3 lo{0.0}, hi{0.0};       // box of every pixel's plane point over all frames

  double distance(const glm::dvec3& p) const { return glm::dot(normal, p) - offset; }
  // View depth (camera z) of pixel (u, v) of frame k on the plane; the TSDF's pixel centres.
  double depth(std::size_t k, std::uint32_t u, std::uint32_t v) const {
    const glm::dmat3 R(poses[k]);
    const glm::dvec3 C(poses[k][3]);
    const glm::dvec3 ray = R * glm::dvec3((u + 0.5 - cx) / fx, (v + 0.5 - cy) / fy, 1.0);
    return (offset - glm::dot(normal, C)) / glm::dot(normal, ray);
  }
};

// Writes `frames` frames (at most 5) into `folder` (emptied first). The plane is
// 0.3 x - 0.2 y - z = -2.5 (normalised) seen from cameras a few centimetres apart, each
// turned a few degrees. cam_params.json goes into the folder unless `params_in_parent`.
inline ReplicaPlane write_replica_plane(const std::filesystem::path& folder, std::size_t frames = 3,
                                        bool params_in_parent = false) {
  namespace fs = std::filesystem;
  ReplicaPlane p;
  p.folder = folder;
  fs::remove_all(folder);
  fs::create_directories(folder / "results");
  const glm::dvec3 n = glm::normalize(glm::dvec3(0.3, -0.2, -1.0));
  p.normal = n;
  p.offset = glm::dot(n, glm::dvec3(0.0, 0.0, 2.5));
  const glm::dvec3 centres[5] = {{0.0, 0.0, 0.0}, {0.08, 0.0, 0.05}, {-0.06, 0.04, 0.0}, {0.0, -0.05, 0.1},
                                 {0.05, 0.05, -0.05}};
  const double yaw_deg[5] = {0.0, 6.0, -5.0, 2.0, -3.0}, pitch_deg[5] = {0.0, -3.0, 4.0, 5.0, -2.0};
  std::ofstream traj(folder / "traj.txt");
  p.lo = glm::dvec3(std::numeric_limits<double>::max());
  p.hi = glm::dvec3(-std::numeric_limits<double>::max());
  for (std::size_t k = 0; k < std::min<std::size_t>(frames, 5); ++k) {
    glm::dmat4 T = glm::rotate(glm::dmat4(1.0), glm::radians(yaw_deg[k]), glm::dvec3(0, 1, 0));
    T = glm::rotate(T, glm::radians(pitch_deg[k]), glm::dvec3(1, 0, 0));
    T[3] = glm::dvec4(centres[k], 1.0);
    p.poses.push_back(T);
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) {
        char num[32];
        std::snprintf(num, sizeof num, "%.17g", T[c][r]);
        traj << num << (r == 3 && c == 3 ? "\n" : " ");
      }
    ImageU16 depth;
    depth.width = p.width;
    depth.height = p.height;
    ImageRGBA8 colour;
    colour.width = p.width;
    colour.height = p.height;
    for (std::uint32_t v = 0; v < p.height; ++v)
      for (std::uint32_t u = 0; u < p.width; ++u) {
        const double z = p.depth(k, u, v);
        depth.pixels.push_back(std::uint16_t(std::lround(z * p.depth_scale)));
        colour.pixels.insert(colour.pixels.end(), {p.colour.r, p.colour.g, p.colour.b, 255});
        const glm::dvec3 world =
            glm::dvec3(T[3]) + glm::dmat3(T) * (glm::dvec3((u + 0.5 - p.cx) / p.fx, (v + 0.5 - p.cy) / p.fy, 1.0) * z);
        p.lo = glm::min(p.lo, world);
        p.hi = glm::max(p.hi, world);
      }
    char stem[32];
    std::snprintf(stem, sizeof stem, "%06zu", k);
    if (auto st = write_png_u16(folder / "results" / ("depth" + std::string(stem) + ".png"), depth); !st)
      ADD_FAILURE() << st.message();
    if (auto st = write_jpeg(folder / "results" / ("frame" + std::string(stem) + ".jpg"), colour); !st)
      ADD_FAILURE() << st.message();
  }
  const fs::path params = (params_in_parent ? folder.parent_path() : folder) / "cam_params.json";
  std::ofstream(params) << "{\"camera\": {\"w\": " << p.width << ", \"h\": " << p.height << ", \"fx\": " << p.fx
                        << ", \"fy\": " << p.fy << ", \"cx\": " << p.cx << ", \"cy\": " << p.cy
                        << ", \"scale\": " << p.depth_scale << "}}\n";
  return p;
}

}  // namespace gauss::test
