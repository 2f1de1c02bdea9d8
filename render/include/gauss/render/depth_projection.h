#pragma once
// The renderer's depth as an OpenXR depth layer wants it. The mesh pass stores linear view
// depth / SPLAT_MESH_DEPTH_SCALE (1 where nothing was drawn; splats write no depth); a
// compositor reading XR_KHR_composition_layer_depth assumes a perspective projection's
// [0, 1] depth for the layer's nearZ / farZ. record() copies a view's depth target into a
// buffer, converts it in place (shaders/depth_projection.comp) and copies the result into
// the layer's depth image.
#include <array>
#include <cstdint>

#include <volk.h>

#include "gauss/engine/result.h"
#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_pipeline.h"

namespace gauss::vk {
class Context;
class Image;
}  // namespace gauss::vk

namespace gauss::render {

// The conversion on the CPU, for tests: the same formula as the shader.
float projected_depth(float stored, double near_z, double far_z);

class DepthProjection {
 public:
  // Buffers for two views of up to max_width x max_height. Errors: sizes, the pipeline.
  static Expected<DepthProjection> create(vk::Context& context, std::uint32_t max_width, std::uint32_t max_height);

  // Records view `view`'s conversion (0 or 1: each view has its own buffer): `depth` (the
  // renderer's D32 target, left in TRANSFER_SRC_OPTIMAL) into `dst` (D32_SFLOAT, same size,
  // in `dst_layout` before and after). A null `depth` means the frame drew no mesh (the
  // target was not written): `dst` is cleared to the far plane (1). Errors: a view index or
  // size out of range, near/far not 0 < near < far (nothing is recorded then).
  Status record(VkCommandBuffer cmd, std::uint32_t view, vk::Image* depth, VkExtent2D extent, VkImage dst,
                VkImageLayout dst_layout, double near_z, double far_z);

 private:
  DepthProjection() = default;
  vk::ComputePipeline pipeline_;
  std::array<vk::Buffer, 2> buffers_;
  std::uint32_t max_width_{0}, max_height_{0};
};

}  // namespace gauss::render
