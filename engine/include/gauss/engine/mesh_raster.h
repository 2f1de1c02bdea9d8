#pragma once
// CPU depth rasterizer for triangle meshes: the oracle for surface accuracy tests and
// benchmarks (the GPU mesh pass renders the same surface on the client).
#include <vector>

#include "gauss/engine/camera.h"
#include "gauss/engine/mesh.h"

namespace gauss {

// View depth (camera z, metres) per pixel, row-major; 0 where no triangle covers the
// pixel. Pixel (i, j) samples (j + 0.5, i + 0.5); depth is interpolated perspective-
// correctly; both windings are drawn. Triangles with a vertex at or behind the near
// plane are skipped (not clipped): callers place cameras so the surface is in front.
std::vector<float> render_mesh_depth(const TriangleMesh& mesh, const Camera& camera);

}  // namespace gauss
