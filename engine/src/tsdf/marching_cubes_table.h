#pragma once
// Marching-cubes case table, derived at start-up instead of typed in by hand.
//
// Corner c of a cell sits at (c & 1, (c >> 1) & 1, (c >> 2) & 1). Edge e joins corners
// kEdgeCorners[e][0] < kEdgeCorners[e][1] (they differ in one bit). A corner is "inside"
// when its signed distance is negative. For each of the 256 inside-masks the table
// lists triangles as triples of edge indices, wound counter-clockwise seen from the
// outside (free space), so normals point toward the camera side of the surface.
//
// Derivation: on every cube face the crossing points are joined into segments; a face
// with four crossings (diagonal corners alike) is resolved by cutting off each inside
// corner separately. The rule depends only on the face's own four corners, so two cells
// sharing a face produce the same segments there and the surface has no cracks. The
// segments close into loops on the cube surface; each loop is fanned into triangles.
#include <array>
#include <cstdint>

namespace gauss::tsdf {

inline constexpr std::array<std::array<std::uint8_t, 2>, 12> kEdgeCorners{{
    {0, 1}, {2, 3}, {4, 5}, {6, 7},  // along x
    {0, 2}, {1, 3}, {4, 6}, {5, 7},  // along y
    {0, 4}, {1, 5}, {2, 6}, {3, 7},  // along z
}};

struct McCase {
  std::uint8_t triangle_count{0};
  std::array<std::uint8_t, 15> edges{};  // at most 5 triangles
};

// The 256 cases, built once (thread-safe static initialisation).
const std::array<McCase, 256>& marching_cubes_table();

}  // namespace gauss::tsdf
