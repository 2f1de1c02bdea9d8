// Image: 2D, one mip, optimal tiling, dedicated allocation, tracked layout.
#include "gauss/render/vk_image.h"

#include <string>
#include <utility>

#include "gauss/render/vk_check.h"
#include "gauss/render/vk_commands.h"
#include "gauss/render/vk_context.h"
#include "vk/image_formats.h"
#include "vk/memory.h"

namespace gauss::vk {
namespace {

// The format features each usage needs; a missing one is reported by name.
struct UsageFeature {
  VkImageUsageFlags usage;
  VkFormatFeatureFlags feature;
  const char* what;
};
constexpr UsageFeature kUsageFeatures[] = {
    {VK_IMAGE_USAGE_STORAGE_BIT, VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT, "storage image"},
    {VK_IMAGE_USAGE_SAMPLED_BIT, VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT, "sampled image"},
    {VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT, VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BIT, "colour attachment"},
    {VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT, "depth attachment"},
    {VK_IMAGE_USAGE_TRANSFER_SRC_BIT, VK_FORMAT_FEATURE_TRANSFER_SRC_BIT, "transfer source"},
    {VK_IMAGE_USAGE_TRANSFER_DST_BIT, VK_FORMAT_FEATURE_TRANSFER_DST_BIT, "transfer destination"},
};

}  // namespace

Expected<Image> Image::create(Context& context, const ImageCreateInfo& info) {
  const std::string what = "image '" + info.name + "'";
  const std::uint32_t max_dim = context.limits().maxImageDimension2D;
  if (info.width == 0 || info.height == 0 || info.width > max_dim || info.height > max_dim) {
    return Error{what + ": extent " + std::to_string(info.width) + "x" + std::to_string(info.height) +
                 " outside 1.." + std::to_string(max_dim)};
  }
  const VkImageUsageFlags usage = info.usage | VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  VkFormatProperties fp{};
  vkGetPhysicalDeviceFormatProperties(context.physical_device(), info.format, &fp);
  for (const UsageFeature& uf : kUsageFeatures) {
    if ((usage & uf.usage) && !(fp.optimalTilingFeatures & uf.feature)) {
      return Error{what + ": format " + std::to_string(static_cast<int>(info.format)) + " cannot be a " + uf.what +
                   " on device '" + context.device_name() + "'"};
    }
  }

  Image img;
  img.context_ = &context;
  img.format_ = info.format;
  img.aspect_ = is_depth_format(info.format) ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT;
  img.width_ = info.width;
  img.height_ = info.height;
  img.name_ = info.name;

  VkImageCreateInfo ci{};
  ci.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
  ci.imageType = VK_IMAGE_TYPE_2D;
  ci.format = info.format;
  ci.extent = {info.width, info.height, 1};
  ci.mipLevels = 1;
  ci.arrayLayers = 1;
  ci.samples = VK_SAMPLE_COUNT_1_BIT;
  ci.tiling = VK_IMAGE_TILING_OPTIMAL;
  ci.usage = usage;
  ci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  ci.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  GAUSS_VK_TRY(vkCreateImage(context.device(), &ci, nullptr, &img.image_));
  context.set_debug_name(VK_OBJECT_TYPE_IMAGE, reinterpret_cast<std::uint64_t>(img.image_), info.name.c_str());

  VkMemoryRequirements req{};
  vkGetImageMemoryRequirements(context.device(), img.image_, &req);
  auto alloc = allocate_memory(context, req, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, what);
  if (!alloc) return alloc.error();
  img.memory_ = alloc->memory;
  GAUSS_VK_TRY(vkBindImageMemory(context.device(), img.image_, img.memory_, 0));

  VkImageViewCreateInfo vci{};
  vci.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
  vci.image = img.image_;
  vci.viewType = VK_IMAGE_VIEW_TYPE_2D;
  vci.format = info.format;
  vci.subresourceRange = {img.aspect_, 0, 1, 0, 1};
  GAUSS_VK_TRY(vkCreateImageView(context.device(), &vci, nullptr, &img.view_));
  return img;
}

Image::~Image() { destroy(); }

Image::Image(Image&& other) noexcept
    : context_(std::exchange(other.context_, nullptr)),
      image_(std::exchange(other.image_, VK_NULL_HANDLE)),
      memory_(std::exchange(other.memory_, VK_NULL_HANDLE)),
      view_(std::exchange(other.view_, VK_NULL_HANDLE)),
      format_(std::exchange(other.format_, VK_FORMAT_UNDEFINED)),
      aspect_(std::exchange(other.aspect_, 0)),
      width_(std::exchange(other.width_, 0)),
      height_(std::exchange(other.height_, 0)),
      layout_(std::exchange(other.layout_, VK_IMAGE_LAYOUT_UNDEFINED)),
      name_(std::move(other.name_)) {}

Image& Image::operator=(Image&& other) noexcept {
  if (this != &other) {
    destroy();
    context_ = std::exchange(other.context_, nullptr);
    image_ = std::exchange(other.image_, VK_NULL_HANDLE);
    memory_ = std::exchange(other.memory_, VK_NULL_HANDLE);
    view_ = std::exchange(other.view_, VK_NULL_HANDLE);
    format_ = std::exchange(other.format_, VK_FORMAT_UNDEFINED);
    aspect_ = std::exchange(other.aspect_, 0);
    width_ = std::exchange(other.width_, 0);
    height_ = std::exchange(other.height_, 0);
    layout_ = std::exchange(other.layout_, VK_IMAGE_LAYOUT_UNDEFINED);
    name_ = std::move(other.name_);
  }
  return *this;
}

void Image::destroy() noexcept {
  if (context_ == nullptr) return;
  (void)vkDeviceWaitIdle(context_->device());
  if (view_) vkDestroyImageView(context_->device(), view_, nullptr);
  if (image_) vkDestroyImage(context_->device(), image_, nullptr);
  if (memory_) vkFreeMemory(context_->device(), memory_, nullptr);
  view_ = VK_NULL_HANDLE;
  image_ = VK_NULL_HANDLE;
  memory_ = VK_NULL_HANDLE;
  context_ = nullptr;
}

void Image::transition(VkCommandBuffer cmd, VkImageLayout new_layout) {
  transition(cmd, new_layout, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
             VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
             VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
}

void Image::transition(VkCommandBuffer cmd, VkImageLayout new_layout, VkPipelineStageFlags2 src_stage,
                       VkAccessFlags2 src_access, VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access) {
  const VkImageMemoryBarrier2 b =
      image_barrier(image_, aspect_, layout_, new_layout, src_stage, src_access, dst_stage, dst_access);
  VkDependencyInfo di{};
  di.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  di.imageMemoryBarrierCount = 1;
  di.pImageMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cmd, &di);
  layout_ = new_layout;
}

Status Image::record_copy_to_buffer(VkCommandBuffer cmd, VkBuffer dst, VkDeviceSize dst_size) {
  const std::uint32_t texel = texel_size(format_);
  if (texel == 0) return Error{"image '" + name_ + "': readback of this format is not supported"};
  const VkDeviceSize needed = VkDeviceSize{width_} * height_ * texel;
  if (dst_size < needed) {
    return Error{"image '" + name_ + "': readback needs " + std::to_string(needed) + " bytes, buffer holds " +
                 std::to_string(dst_size)};
  }
  transition(cmd, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
  VkBufferImageCopy region{};
  region.bufferOffset = 0;
  region.bufferRowLength = 0;  // tightly packed
  region.bufferImageHeight = 0;
  region.imageSubresource = {aspect_, 0, 0, 1};
  region.imageExtent = {width_, height_, 1};
  vkCmdCopyImageToBuffer(cmd, image_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, dst, 1, &region);
  return Ok{};
}

}  // namespace gauss::vk
