#pragma once
// Triangle meshes with vertex colours as PLY (the TSDF surface proxy).
//
// Accepted input (ascii, binary little or big endian):
//   element vertex: x y z (any numeric type), optional red green blue (integer types, 0..255);
//                   other properties ignored. Without colours every vertex is white (255) and
//                   the report says so.
//   element face:   property list <count> <index> vertex_indices (or vertex_index); count type
//                   uchar/ushort/uint (any integer type), index type int/uint/ushort/... (any
//                   integer type). A polygon of n >= 3 vertices becomes a fan of n - 2 triangles
//                   (0, i, i+1): quads split into two triangles; exact for convex polygons.
//                   No face element: a point-only mesh with no triangles.
// Other elements are skipped. Errors name the input and the face/vertex/byte offset or line:
// NaN/Inf positions, an index out of range, a polygon of fewer than 3 vertices, counts that
// disagree with the data, missing/duplicated properties.
#include <cstdint>
#include <filesystem>
#include <span>
#include <string_view>
#include <vector>

#include "gauss/engine/mesh.h"
#include "gauss/engine/ply_gaussian.h"  // PlyFormat
#include "gauss/engine/result.h"

namespace gauss {

struct PlyMeshReport {
  PlyFormat format{PlyFormat::BinaryLittleEndian};
  bool has_colors{false};
  std::size_t polygon_count{0};  // faces in the file (before splitting into triangles)
  std::size_t split_polygons{0}; // faces with more than 3 vertices
};

struct PlyMeshScene {
  TriangleMesh mesh;
  PlyMeshReport report;
};

Expected<PlyMeshScene> parse_mesh_ply(std::span<const std::uint8_t> bytes, std::string_view name);
Expected<PlyMeshScene> read_mesh_ply(const std::filesystem::path& path);

struct PlyMeshWriteOptions {
  PlyFormat format{PlyFormat::BinaryLittleEndian};
};

// Writes x y z float, red green blue uchar, and faces as "property list uchar int vertex_indices".
// Fails on colours of a different length than positions (an empty colour array is written as
// white), an index count not a multiple of 3, an index out of range, a non-finite position or
// more vertices than an int index can address.
Expected<std::vector<std::uint8_t>> encode_mesh_ply(const TriangleMesh& mesh,
                                                    const PlyMeshWriteOptions& options = {});
Status write_mesh_ply(const std::filesystem::path& path, const TriangleMesh& mesh,
                      const PlyMeshWriteOptions& options = {});

}  // namespace gauss
