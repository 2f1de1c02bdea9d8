#include "eye_copy.h"

#include "gauss/render/vk_commands.h"
#include "gauss/render/vk_image.h"

namespace gauss::xr_app {

namespace {

void barrier(VkCommandBuffer cmd, VkImage image, VkImageLayout from, VkImageLayout to, VkPipelineStageFlags2 src_stage,
             VkAccessFlags2 src_access, VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access) {
  vk::record_image_barrier(cmd, vk::image_barrier(image, VK_IMAGE_ASPECT_COLOR_BIT, from, to, src_stage, src_access,
                                                  dst_stage, dst_access));
}

}  // namespace

Status record_eye_copy(VkCommandBuffer cmd, render::SplatRenderer& renderer, const xr::FrameTarget& target,
                       render::DepthProjection* depth) {
  for (std::uint32_t eye = 0; eye < 2; ++eye) {
    vk::Image& src = renderer.target(eye).color();
    if (src.width() != target.extent.width || src.height() != target.extent.height)
      return Error{"gauss-xr: the renderer's eye image is " + std::to_string(src.width()) + "x" +
                   std::to_string(src.height()) + ", the swapchain's " + std::to_string(target.extent.width) + "x" +
                   std::to_string(target.extent.height)};
    // The blend pass leaves the view in TRANSFER_DST after its buffer->image copy.
    src.transition(cmd, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                   VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
    const VkImage dst = target.images[eye];
    barrier(cmd, dst, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
            VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_2_TRANSFER_BIT,
            VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_2_TRANSFER_READ_BIT, VK_PIPELINE_STAGE_2_TRANSFER_BIT,
            VK_ACCESS_2_TRANSFER_WRITE_BIT);
    VkImageCopy region{};
    region.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.extent = {target.extent.width, target.extent.height, 1};
    vkCmdCopyImage(cmd, src.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, dst, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1,
                   &region);
    barrier(cmd, dst, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
            VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
            VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_2_TRANSFER_BIT,
            VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_2_TRANSFER_READ_BIT);
    if (depth != nullptr && target.depth_images[eye] != VK_NULL_HANDLE) {
      vk::Image* drawn = renderer.has_mesh() ? &renderer.target(eye).depth() : nullptr;
      if (auto st = depth->record(cmd, eye, drawn, target.extent, target.depth_images[eye],
                                  VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL, target.near_z, target.far_z);
          !st)
        return st;
    }
  }
  return Ok{};
}

}  // namespace gauss::xr_app
