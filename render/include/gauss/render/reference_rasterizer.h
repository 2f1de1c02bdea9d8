#pragma once
// CPU reference rasterizer: the splat math of splat_math.h in double precision, with the
// same 16x16 tile semantics as the GPU pipeline. It is the test oracle for the Vulkan path,
// so it favours being obviously right over being fast (it is still tiled, so 100k-Gaussian
// frames take seconds, not minutes).
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/camera.h"
#include "gauss/engine/gaussian.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/image_io.h"
#include "gauss/engine/result.h"
#include "gauss/render/splat_math.h"

namespace gauss::render {

// Why a slot produced no splat (or Visible when it did). The order is the order of the tests.
enum class SplatCull : std::uint8_t {
  Visible = 0,
  Empty,       // slot not occupied
  NonFinite,   // NaN/Inf in a field the math reads: rejected, counted, never drawn
  Removed,     // edit tint "removed" past its fade-out
  Near,        // view depth t.z <= kNearCull (includes everything behind the camera)
  Degenerate,  // det(cov2D) == 0 or a non-finite 2D footprint
  OffScreen,   // radius 0 or empty tile rectangle
  BehindMesh,  // whole tile rectangle behind the mesh by more than the margin
};

// A Gaussian after preprocess (steps 1-11 of splat_math.h).
struct ProjectedSplat {
  SplatCull cull{SplatCull::Empty};
  std::uint32_t slot{0};
  glm::dvec3 view{0.0};        // t = W p + w
  double u{0.0}, v{0.0};       // centre in pixels (OpenCV)
  glm::dvec3 cov2d{0.0};       // (a, b, c) after dilation
  glm::dvec3 conic{0.0};       // (A, B, C)
  double radius{0.0};          // integer-valued pixels (double: can exceed int for huge Gaussians)
  std::uint32_t tile_min_x{0}, tile_min_y{0}, tile_max_x{0}, tile_max_y{0};  // max exclusive
  glm::dvec3 colour{0.0};      // after SH, +0.5, max(0), tints
  double opacity{0.0};         // after sigmoid and tints
  float depth_key{0.0f};       // float32(t.z)
};

// SH colour (before +0.5 and the clamp) of g in direction dir (unit), up to `degree`.
glm::dvec3 eval_sh(const Gaussian& g, int degree, const glm::dvec3& dir);

// True when every field the splat math reads for `degree` is finite.
bool gaussian_is_finite(const Gaussian& g, int degree);

// Steps 1-11 for one slot (everything except the mesh cull, which needs the per-tile
// depth buffer). `camera` must be valid (see render_reference).
ProjectedSplat project_splat(const Gaussian& g, std::uint32_t slot, int sh_degree, const Camera& camera,
                             bool highlighted = false, EditTintState edit = {});

// The mesh layer of one view, as the mesh pass leaves it.
struct MeshLayer {
  const ImageRGBA8* colour{nullptr};  // width x height; the background where present
  std::span<const float> view_depth;  // width * height, metres > 0; +infinity (not 0) where no triangle
  double margin{kDefaultMeshMargin};
};

struct ReferenceOptions {
  glm::dvec3 clear_colour{0.0};                 // background without a mesh
  const MeshLayer* mesh{nullptr};               // optional
  std::span<const ObjectId> highlight_objects;  // empty: no highlight
  std::span<const EditTintState> edit_tints;    // empty, or one per slot
  // Only rows [row_begin, row_end) are blended (big scenes: a subset keeps the oracle
  // affordable). Other pixels are left at the background; stats still cover the whole view.
  std::uint32_t row_begin{0};
  std::uint32_t row_end{std::numeric_limits<std::uint32_t>::max()};
  unsigned threads{1};  // blend threads (tile rows are split; the result does not depend on it)
};

struct ReferenceStats {
  std::uint64_t slots{0};
  std::uint64_t occupied{0};
  std::uint64_t rejected_nonfinite{0};
  std::uint64_t removed_faded{0};
  std::uint64_t culled_near{0};
  std::uint64_t culled_degenerate{0};
  std::uint64_t culled_offscreen{0};
  std::uint64_t culled_mesh{0};
  std::uint64_t visible{0};     // splats that touch at least one tile
  std::uint64_t tile_pairs{0};  // (tile, splat) pairs over the whole view
};

struct ReferenceImage {
  std::uint32_t width{0}, height{0};
  std::uint32_t row_begin{0}, row_end{0};  // rows actually blended
  std::vector<double> rgb;                 // 3 per pixel, C + T * background, not clamped
  std::vector<double> transmittance;       // final T per pixel
  ImageRGBA8 rgba8;                        // to_unorm8 of rgb, alpha 255
  ReferenceStats stats;
};

// Renders one view. `occupied` is empty (every slot occupied) or one flag per slot.
// Fails, naming the argument, on: sh_degree outside 0..3; a camera with zero or > 16384
// size, non-positive or non-finite intrinsics or a non-finite matrix; mismatched occupied /
// edit_tints / mesh image sizes; a NaN, zero or negative mesh depth; an empty row range.
// Non-finite Gaussians are not an error: they are skipped and counted.
Expected<ReferenceImage> render_reference(std::span<const Gaussian> slots, std::span<const std::uint8_t> occupied,
                                          int sh_degree, const Camera& camera, const ReferenceOptions& options = {});

// Camera validity check shared by the reference and the CLI (message names the field).
Status validate_camera(const Camera& camera);

}  // namespace gauss::render
