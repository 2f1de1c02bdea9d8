// OffscreenTarget: RGBA8 colour + D32 depth for the mesh pass (dynamic rendering) and
// the compute passes, with blocking readback.
#include <cstring>

#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_commands.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_image.h"

namespace gauss::vk {

Expected<OffscreenTarget> OffscreenTarget::create(Context& context, std::uint32_t width, std::uint32_t height,
                                                  const std::string& name) {
  OffscreenTarget t;
  auto color = Image::create(context, {.width = width,
                                       .height = height,
                                       .format = kOffscreenColorFormat,
                                       .usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_STORAGE_BIT |
                                                VK_IMAGE_USAGE_SAMPLED_BIT,
                                       .name = name + " colour"});
  if (!color) return color.error();
  auto depth = Image::create(context, {.width = width,
                                       .height = height,
                                       .format = kOffscreenDepthFormat,
                                       .usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT,
                                       .name = name + " depth"});
  if (!depth) return depth.error();
  t.color_ = std::move(*color);
  t.depth_ = std::move(*depth);
  return t;
}

void OffscreenTarget::begin_rendering(VkCommandBuffer cmd, bool clear, const ClearValues& values) {
  color_.transition(cmd, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
  depth_.transition(cmd, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
  VkRenderingAttachmentInfo ca{};
  ca.sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO;
  ca.imageView = color_.view();
  ca.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  ca.loadOp = clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
  ca.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  std::memcpy(ca.clearValue.color.float32, values.color, sizeof(values.color));
  VkRenderingAttachmentInfo da{};
  da.sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO;
  da.imageView = depth_.view();
  da.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  da.loadOp = clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
  da.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  da.clearValue.depthStencil = {values.depth, 0};
  VkRenderingInfo ri{};
  ri.sType = VK_STRUCTURE_TYPE_RENDERING_INFO;
  ri.renderArea = {{0, 0}, extent()};
  ri.layerCount = 1;
  ri.colorAttachmentCount = 1;
  ri.pColorAttachments = &ca;
  ri.pDepthAttachment = &da;
  vkCmdBeginRendering(cmd, &ri);
  const VkViewport viewport{0.0f, 0.0f, static_cast<float>(width()), static_cast<float>(height()), 0.0f, 1.0f};
  const VkRect2D scissor{{0, 0}, extent()};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
}

void OffscreenTarget::end_rendering(VkCommandBuffer cmd) { vkCmdEndRendering(cmd); }

void OffscreenTarget::record_clear(VkCommandBuffer cmd, const ClearValues& values) {
  color_.transition(cmd, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
  depth_.transition(cmd, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
  VkClearColorValue cv{};
  std::memcpy(cv.float32, values.color, sizeof(values.color));
  const VkImageSubresourceRange color_range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  vkCmdClearColorImage(cmd, color_.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &cv, 1, &color_range);
  const VkClearDepthStencilValue dv{values.depth, 0};
  const VkImageSubresourceRange depth_range{VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, 1};
  vkCmdClearDepthStencilImage(cmd, depth_.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &dv, 1, &depth_range);
}

namespace {

// Copies `image` into a host-visible buffer (blocking) and returns that buffer.
Expected<Buffer> read_image(Context& context, Image& image, VkDeviceSize bytes) {
  auto staging = Buffer::create(context, {.size = bytes,
                                          .usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                          .memory = MemoryUsage::HostVisible,
                                          .name = image.name() + " readback"});
  if (!staging) return staging.error();
  Status recorded = Ok{};
  auto st = context.submit_and_wait([&](VkCommandBuffer cmd) {
    recorded = image.record_copy_to_buffer(cmd, staging->handle(), staging->size());
    memory_barrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
  });
  if (!recorded) return recorded.error();
  if (!st) return st.error();
  return staging;
}

}  // namespace

Expected<ImageRGBA8> OffscreenTarget::read_color(Context& context) {
  if (!color_.valid()) return Error{"OffscreenTarget::read_color on an empty target"};
  const VkDeviceSize bytes = VkDeviceSize{width()} * height() * 4;
  auto staging = read_image(context, color_, bytes);
  if (!staging) return staging.error();
  ImageRGBA8 out;
  out.width = width();
  out.height = height();
  out.pixels.resize(bytes);
  std::memcpy(out.pixels.data(), staging->mapped(), bytes);
  return out;
}

Expected<std::vector<float>> OffscreenTarget::read_depth(Context& context) {
  if (!depth_.valid()) return Error{"OffscreenTarget::read_depth on an empty target"};
  const VkDeviceSize bytes = VkDeviceSize{width()} * height() * sizeof(float);
  auto staging = read_image(context, depth_, bytes);
  if (!staging) return staging.error();
  std::vector<float> out(static_cast<std::size_t>(width()) * height());
  std::memcpy(out.data(), staging->mapped(), bytes);
  return out;
}

Status OffscreenTarget::write_color_png(Context& context, const std::filesystem::path& path) {
  auto image = read_color(context);
  if (!image) return image.error();
  return write_png(path, *image);
}

}  // namespace gauss::vk
