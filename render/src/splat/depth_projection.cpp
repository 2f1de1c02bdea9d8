#include "gauss/render/depth_projection.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "depth_projection_layout.h"
#include "gauss/render/vk_commands.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_image.h"
#include "gauss/shaders/depth_projection.comp.spv.h"
#include "splat_layout.h"

namespace gauss::render {

float projected_depth(float stored, double near_z, double far_z) {
  if (!(stored < 1.0f)) return 1.0f;
  const float z = stored * float(gpu::SPLAT_MESH_DEPTH_SCALE);
  const float n = float(near_z), f = float(far_z);
  const float d = f * (z - n) / (z * (f - n));
  return z <= n ? 0.0f : std::clamp(d, 0.0f, 1.0f);
}

Expected<DepthProjection> DepthProjection::create(vk::Context& context, std::uint32_t max_width,
                                                  std::uint32_t max_height) {
  if (max_width == 0 || max_height == 0) return Error{"DepthProjection: empty size"};
  DepthProjection p;
  p.max_width_ = max_width;
  p.max_height_ = max_height;
  auto pipeline = vk::ComputePipeline::create(
      context, {.name = "depth projection",
                .shader = vk::spirv(gauss_spv_depth_projection_comp),
                .bindings = {{gpu::DEPTH_PROJECTION_BINDING_DEPTH, vk::DescriptorKind::StorageBuffer}},
                .push_constant_size = sizeof(gpu::DepthProjectionPush)});
  if (!pipeline) return pipeline.error();
  p.pipeline_ = std::move(*pipeline);
  for (std::size_t v = 0; v < 2; ++v) {
    auto b = vk::Buffer::create(context, {.size = VkDeviceSize(max_width) * max_height * 4,
                                          .name = "depth projection " + std::to_string(v)});
    if (!b) return b.error();
    p.buffers_[v] = std::move(*b);
  }
  return p;
}

namespace {

// A barrier on the layer's depth image (mip 0, layer 0, depth aspect).
void depth_barrier(VkCommandBuffer cmd, VkImage image, VkImageLayout from, VkImageLayout to,
                   VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access, VkPipelineStageFlags2 dst_stage,
                   VkAccessFlags2 dst_access) {
  vk::record_image_barrier(cmd, vk::image_barrier(image, VK_IMAGE_ASPECT_DEPTH_BIT, from, to, src_stage, src_access,
                                                  dst_stage, dst_access));
}

}  // namespace

Status DepthProjection::record(VkCommandBuffer cmd, std::uint32_t view, vk::Image* depth, VkExtent2D extent,
                               VkImage dst, VkImageLayout dst_layout, double near_z, double far_z) {
  if (view > 1) return Error{"DepthProjection: view " + std::to_string(view) + " (0 or 1)"};
  const std::uint32_t w = extent.width, h = extent.height;
  if (depth != nullptr && (depth->width() != w || depth->height() != h))
    return Error{"DepthProjection: the depth target is " + std::to_string(depth->width()) + "x" +
                 std::to_string(depth->height()) + ", the layer's image " + std::to_string(w) + "x" + std::to_string(h)};
  if (w > max_width_ || h > max_height_)
    return Error{"DepthProjection: a " + std::to_string(w) + "x" + std::to_string(h) + " view exceeds " +
                 std::to_string(max_width_) + "x" + std::to_string(max_height_)};
  if (!(near_z > 0.0 && far_z > near_z && std::isfinite(far_z)))
    return Error{"DepthProjection: near " + std::to_string(near_z) + " and far " + std::to_string(far_z) +
                 " must satisfy 0 < near < far"};
  const VkPipelineStageFlags2 depth_stages =
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  if (depth == nullptr) {  // no mesh drawn: everything is at the far plane
    depth_barrier(cmd, dst, dst_layout, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, depth_stages | VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                  VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT | VK_ACCESS_2_TRANSFER_READ_BIT,
                  VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    const VkClearDepthStencilValue far{1.0f, 0};
    const VkImageSubresourceRange range{VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, 1};
    vkCmdClearDepthStencilImage(cmd, dst, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &far, 1, &range);
    depth_barrier(cmd, dst, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, dst_layout, VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                  VK_ACCESS_2_TRANSFER_WRITE_BIT, depth_stages | VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                  VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_TRANSFER_READ_BIT);
    return Ok{};
  }
  const vk::Buffer& buf = buffers_[view];
  const VkDeviceSize bytes = VkDeviceSize(w) * h * 4;
  // An earlier frame's conversion may still read or write this buffer (write after read/write).
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
  if (auto st = depth->record_copy_to_buffer(cmd, buf.handle(), buf.size()); !st) return st;
  vk::transfer_to_compute_barrier(cmd);
  if (auto st = pipeline_.bind(cmd, {{gpu::DEPTH_PROJECTION_BINDING_DEPTH, &buf, 0, bytes}}); !st) return st;
  const gpu::DepthProjectionPush push{w * h, float(gpu::SPLAT_MESH_DEPTH_SCALE), float(near_z), float(far_z)};
  pipeline_.push_constants(cmd, push);
  vkCmdDispatch(cmd, (w * h + gpu::DEPTH_PROJECTION_WORKGROUP - 1) / gpu::DEPTH_PROJECTION_WORKGROUP, 1, 1);
  vk::compute_to_transfer_barrier(cmd);
  depth_barrier(cmd, dst, dst_layout, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                depth_stages | VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT | VK_ACCESS_2_TRANSFER_READ_BIT,
                VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 0, 1};
  region.imageExtent = {w, h, 1};
  vkCmdCopyBufferToImage(cmd, buf.handle(), dst, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
  depth_barrier(cmd, dst, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, dst_layout, VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                VK_ACCESS_2_TRANSFER_WRITE_BIT, depth_stages | VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_TRANSFER_READ_BIT);
  return Ok{};
}

}  // namespace gauss::render
