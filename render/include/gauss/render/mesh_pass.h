#pragma once
// gauss::render::MeshPass: rasterizes the TSDF surface mesh (vertex colours) into an
// OffscreenTarget: colour = the splats' background, depth attachment = the linear VIEW
// depth t.z / SPLAT_MESH_DEPTH_SCALE (shaders/shared/splat_layout.h), exact and cleared to
// 1.0 (= no triangle). The splat passes read both (splat_math.h "Mesh").
// Pixel (i, j) samples (j + 0.5, i + 0.5) with the OpenCV projection, like the splats.
#include <cstdint>
#include <memory>

#include <glm/vec3.hpp>

#include "gauss/engine/camera.h"
#include "gauss/engine/mesh.h"
#include "gauss/engine/result.h"
#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_image.h"
#include "gauss/render/vk_pipeline.h"

namespace gauss::vk {
class Context;
}

namespace gauss::render {

class MeshPass {
 public:
  static Expected<MeshPass> create(vk::Context& context);

  MeshPass() = default;
  MeshPass(MeshPass&&) noexcept = default;
  MeshPass& operator=(MeshPass&&) noexcept = default;

  // Uploads a mesh (replacing the previous one). Errors, with nothing changed: colours
  // not one per position, an index count not a multiple of 3, an index out of range,
  // a non-finite position, an empty mesh.
  Status set_mesh(vk::Context& context, const TriangleMesh& mesh);
  void clear_mesh() noexcept;
  bool has_mesh() const noexcept { return index_count_ > 0; }
  std::uint32_t triangle_count() const noexcept { return index_count_ / 3; }

  // Records the pass into `target` (cleared to clear_colour and depth 1.0 first). Leaves
  // colour in COLOR_ATTACHMENT layout and depth in DEPTH_ATTACHMENT layout. Near/far from
  // the camera (fragments outside are clipped). Requires has_mesh().
  void record(VkCommandBuffer cmd, vk::OffscreenTarget& target, const Camera& camera,
              const glm::vec3& clear_colour) const;

  // Converts a depth attachment value read back from the target into metres
  // (+infinity where no triangle covers the pixel).
  static float stored_to_view_depth(float stored) noexcept;

 private:
  vk::GraphicsPipeline pipeline_;
  vk::Buffer vertices_;
  vk::Buffer indices_;
  std::uint32_t index_count_{0};
};

}  // namespace gauss::render
