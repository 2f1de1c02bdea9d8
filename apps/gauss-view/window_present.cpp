// Window, per frame: the source image blitted (letterboxed) or copied into the swapchain
// image, the UI on top, the transition to PRESENT_SRC_KHR, submit + present, and the
// optional screenshot read back from the same image. Contract in window.h.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "gauss/engine/image_io.h"
#include "gauss/render/vk_check.h"
#include "gauss/render/vk_commands.h"
#include "imgui_layer.h"
#include "window.h"

namespace gauss::view {
namespace {

// Colour-image barriers (window images have one aspect, one mip, one layer).
VkImageMemoryBarrier2 image_barrier(VkImage image, VkImageLayout old_layout, VkImageLayout new_layout,
                                    VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                                    VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access) {
  return vk::image_barrier(image, VK_IMAGE_ASPECT_COLOR_BIT, old_layout, new_layout, src_stage, src_access, dst_stage,
                           dst_access);
}

void barriers(VkCommandBuffer cmd, const VkImageMemoryBarrier2* images, std::uint32_t image_count,
              const VkBufferMemoryBarrier2* buffer = nullptr) {
  VkDependencyInfo dep{};
  dep.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  dep.imageMemoryBarrierCount = image_count;
  dep.pImageMemoryBarriers = images;
  dep.bufferMemoryBarrierCount = buffer != nullptr ? 1u : 0u;
  dep.pBufferMemoryBarriers = buffer;
  vkCmdPipelineBarrier2(cmd, &dep);
}

bool is_bgra(VkFormat f) { return f == VK_FORMAT_B8G8R8A8_UNORM || f == VK_FORMAT_B8G8R8A8_SRGB; }
bool is_rgba(VkFormat f) { return f == VK_FORMAT_R8G8B8A8_UNORM || f == VK_FORMAT_R8G8B8A8_SRGB; }

// The largest rectangle of the source's aspect ratio inside `dst`, centred.
Viewport fit(VkExtent2D src, VkExtent2D dst) {
  const double scale = std::min(static_cast<double>(dst.width) / src.width, static_cast<double>(dst.height) / src.height);
  Viewport v;
  v.width = std::clamp<std::uint32_t>(static_cast<std::uint32_t>(std::lround(src.width * scale)), 1, dst.width);
  v.height = std::clamp<std::uint32_t>(static_cast<std::uint32_t>(std::lround(src.height * scale)), 1, dst.height);
  v.x = static_cast<std::int32_t>((dst.width - v.width) / 2);
  v.y = static_cast<std::int32_t>((dst.height - v.height) / 2);
  return v;
}

}  // namespace

void Window::request_screenshot(const std::filesystem::path& path) { screenshot_path_ = path; }

Status Window::record_present(VkCommandBuffer cmd, const SourceImage& src) {
  if (src.image == VK_NULL_HANDLE) return record_present(cmd, std::span<const SourceImage>{});
  return record_present(cmd, std::span<const SourceImage>(&src, 1));
}

Status Window::record_present(VkCommandBuffer cmd, std::span<const SourceImage> sources) {
  if (!image_index_) return Error{"Window::record_present: no acquired image (acquire() first)"};
  if (sources.size() > kMaxSources) {
    return Error{"Window::record_present: " + std::to_string(sources.size()) + " sources, at most " +
                 std::to_string(kMaxSources)};
  }
  const std::uint32_t index = *image_index_;
  const VkImage dst = swapchain_->image(index);
  const VkExtent2D ext = swapchain_->extent();
  const VkFormat dst_format = swapchain_->format();
  const auto n = static_cast<std::uint32_t>(sources.size());
  for (const SourceImage& src : sources) {
    if (src.image == VK_NULL_HANDLE) return Error{"Window::record_present: a side-by-side source without an image"};
    if (src.layout != VK_IMAGE_LAYOUT_GENERAL && src.layout != VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL) {
      return Error{"Window::record_present: the source image must be in GENERAL or TRANSFER_SRC_OPTIMAL layout, not " +
                   std::to_string(static_cast<int>(src.layout))};
    }
    if (src.extent.width == 0 || src.extent.height == 0) return Error{"Window::record_present: empty source extent"};
    if (!is_rgba(src.format) && !is_bgra(src.format)) {
      return Error{"Window::record_present: source format " + std::to_string(static_cast<int>(src.format)) +
                   " is not RGBA8/BGRA8"};
    }
  }
  if (n > 0 && ext.width < n) return Error{"Window::record_present: the swapchain is narrower than its columns"};
  const bool want_screenshot = screenshot_path_.has_value();
  if (want_screenshot && !(swapchain_->usage() & VK_IMAGE_USAGE_TRANSFER_SRC_BIT)) {
    screenshot_path_.reset();
    return Error{"Window: the surface cannot read its images back (no TRANSFER_SRC usage), so no screenshot"};
  }

  // Column i spans [i * W / n, (i + 1) * W / n); each source is fitted into its column.
  std::uint64_t covered = 0;
  for (std::uint32_t i = 0; i < kMaxSources; ++i) {
    viewports_[i] = Viewport{};
    if (i >= n) continue;
    const std::uint32_t x0 = i * ext.width / n, x1 = (i + 1) * ext.width / n;
    Viewport v = fit(sources[i].extent, {x1 - x0, ext.height});
    v.x += static_cast<std::int32_t>(x0);
    viewports_[i] = v;
    covered += std::uint64_t{v.width} * v.height;
  }
  const bool covers = covered == std::uint64_t{ext.width} * ext.height;

  // Acquire semaphore is waited at TRANSFER (Swapchain::kAcquireWaitStage): the first
  // barrier's source stage chains to it. Old contents are discarded (UNDEFINED).
  VkImageMemoryBarrier2 first[1 + kMaxSources];
  first[0] = image_barrier(dst, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                           vk::Swapchain::kAcquireWaitStage, VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                           VK_ACCESS_2_TRANSFER_WRITE_BIT);
  for (std::uint32_t i = 0; i < n; ++i) {
    first[1 + i] = image_barrier(sources[i].image, sources[i].layout, sources[i].layout, sources[i].written_stage,
                                 sources[i].written_access, VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                                 VK_ACCESS_2_TRANSFER_READ_BIT);
  }
  barriers(cmd, first, 1 + n);

  if (!covers) {
    VkClearColorValue clear{};
    std::memcpy(clear.float32, info_.clear_color, sizeof(clear.float32));
    const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdClearColorImage(cmd, dst, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &clear, 1, &range);
    if (n > 0) {
      const VkImageMemoryBarrier2 waw =
          image_barrier(dst, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                        VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                        VK_ACCESS_2_TRANSFER_WRITE_BIT);
      barriers(cmd, &waw, 1);
    }
  }
  const VkImageSubresourceLayers layers{VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  for (std::uint32_t i = 0; i < n; ++i) {
    const SourceImage& src = sources[i];
    const Viewport& vp = viewports_[i];
    // The columns are disjoint, so the writes need no barrier between them.
    const bool same_size = src.extent.width == vp.width && src.extent.height == vp.height;
    if (same_size && src.format == dst_format) {
      // Same channel order and size: a byte copy (a copy between RGBA and BGRA would
      // swap red and blue, so those go through the blit below).
      VkImageCopy region{};
      region.srcSubresource = layers;
      region.dstSubresource = layers;
      region.dstOffset = {vp.x, vp.y, 0};
      region.extent = {vp.width, vp.height, 1};
      vkCmdCopyImage(cmd, src.image, src.layout, dst, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
      continue;
    }
    VkFormatProperties sp{};
    VkFormatProperties dp{};
    vkGetPhysicalDeviceFormatProperties(context_->physical_device(), src.format, &sp);
    vkGetPhysicalDeviceFormatProperties(context_->physical_device(), dst_format, &dp);
    if (!(sp.optimalTilingFeatures & VK_FORMAT_FEATURE_BLIT_SRC_BIT) ||
        !(dp.optimalTilingFeatures & VK_FORMAT_FEATURE_BLIT_DST_BIT)) {
      return Error{"Window::record_present: the device cannot blit format " +
                   std::to_string(static_cast<int>(src.format)) + " to the swapchain format " +
                   std::to_string(static_cast<int>(dst_format))};
    }
    const bool linear = !same_size && (sp.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT);
    VkImageBlit region{};
    region.srcSubresource = layers;
    region.dstSubresource = layers;
    region.srcOffsets[1] = {static_cast<std::int32_t>(src.extent.width), static_cast<std::int32_t>(src.extent.height), 1};
    region.dstOffsets[0] = {vp.x, vp.y, 0};
    region.dstOffsets[1] = {vp.x + static_cast<std::int32_t>(vp.width), vp.y + static_cast<std::int32_t>(vp.height), 1};
    vkCmdBlitImage(cmd, src.image, src.layout, dst, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region,
                   linear ? VK_FILTER_LINEAR : VK_FILTER_NEAREST);
  }

  const VkImageMemoryBarrier2 to_ui = image_barrier(
      dst, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_TRANSFER_BIT,
      VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
      VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
  barriers(cmd, &to_ui, 1);
  ui_->record(cmd, index);

  if (want_screenshot) return record_screenshot_copy(cmd, dst);
  // Presentation needs no stage or access (the semaphore signal covers the transition).
  const VkImageMemoryBarrier2 to_present =
      image_barrier(dst, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR,
                    VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                    VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE);
  barriers(cmd, &to_present, 1);
  return Ok{};
}

Status Window::record_screenshot_copy(VkCommandBuffer cmd, VkImage image) {
  auto rb = std::make_unique<Readback>();
  rb->extent = swapchain_->extent();
  rb->format = swapchain_->format();
  rb->path = *screenshot_path_;
  screenshot_path_.reset();
  auto buffer = vk::Buffer::create(*context_, {.size = VkDeviceSize{rb->extent.width} * rb->extent.height * 4,
                                               .usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                               .memory = vk::MemoryUsage::HostVisible,
                                               .name = "window screenshot"});
  if (!buffer) return Error{"Window screenshot: " + buffer.message()};
  rb->buffer = std::move(*buffer);

  const VkImageMemoryBarrier2 to_src =
      image_barrier(image, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                    VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                    VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
  barriers(cmd, &to_src, 1);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {rb->extent.width, rb->extent.height, 1};
  vkCmdCopyImageToBuffer(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, rb->buffer.handle(), 1, &region);
  const VkImageMemoryBarrier2 to_present =
      image_barrier(image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR,
                    VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE);
  VkBufferMemoryBarrier2 to_host{};
  to_host.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2;
  to_host.srcStageMask = VK_PIPELINE_STAGE_2_TRANSFER_BIT;
  to_host.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  to_host.dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT;
  to_host.dstAccessMask = VK_ACCESS_2_HOST_READ_BIT;
  to_host.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  to_host.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  to_host.buffer = rb->buffer.handle();
  to_host.size = VK_WHOLE_SIZE;
  barriers(cmd, &to_present, 1, &to_host);
  readback_ = std::move(rb);
  return Ok{};
}

Status Window::submit_and_present(VkCommandBuffer cmd, VkFence fence) {
  if (!image_index_) return Error{"Window::submit_and_present: no acquired image (acquire() first)"};
  image_index_.reset();
  auto presented = swapchain_->submit_and_present(cmd, fence);
  if (!presented) {
    readback_.reset();
    return presented.error();
  }
  if (readback_) return finish_screenshot(fence);
  return Ok{};
}

Status Window::finish_screenshot(VkFence fence) {
  std::unique_ptr<Readback> rb = std::move(readback_);
  const VkDevice dev = context_->device();
  if (fence != VK_NULL_HANDLE) {
    GAUSS_VK_TRY(vkWaitForFences(dev, 1, &fence, VK_TRUE, UINT64_MAX));
  } else {
    GAUSS_VK_TRY(vkQueueWaitIdle(context_->queue()));
  }
  ImageRGBA8 img{rb->extent.width, rb->extent.height, std::vector<std::uint8_t>(rb->buffer.size())};
  if (auto st = rb->buffer.download(img.pixels.data(), img.pixels.size()); !st) return st;
  screenshot_result_ = ScreenshotResult{rb->path, Ok{}};
  const bool bgra = is_bgra(rb->format);
  for (std::size_t p = 0; p < img.pixels.size(); p += 4) {
    if (bgra) std::swap(img.pixels[p + 0], img.pixels[p + 2]);
    // The surface composites opaquely (alpha ignored); the PNG shows what the screen shows.
    img.pixels[p + 3] = 255;
  }
  screenshot_result_->written = write_png(rb->path, img);
  return Ok{};
}

}  // namespace gauss::view
