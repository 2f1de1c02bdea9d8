#pragma once
// gauss::vk::Image (RAII 2D image + view with its current layout tracked) and
// OffscreenTarget: an RGBA8 colour + D32 depth pair that a graphics pipeline renders
// into (dynamic rendering) and compute reads/writes (colour as a storage image, depth
// as a sampled image), with readback to gauss::ImageRGBA8 / PNG.
//
// Layout tracking: transition() emits a synchronization2 image barrier from the layout
// the image was last transitioned to. The tracked layout is the layout at the end of
// the recorded commands, so record commands for one image in submission order.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <volk.h>

#include "gauss/engine/image_io.h"
#include "gauss/engine/result.h"

namespace gauss::vk {

class Context;

struct ImageCreateInfo {
  std::uint32_t width{0};
  std::uint32_t height{0};
  VkFormat format{VK_FORMAT_R8G8B8A8_UNORM};
  // TRANSFER_SRC | TRANSFER_DST are always added (clears, readback).
  VkImageUsageFlags usage{VK_IMAGE_USAGE_STORAGE_BIT};
  std::string name{"image"};
};

class Image {
 public:
  // Errors: zero or over-limit extent, a format that does not support the usage
  // (checked with vkGetPhysicalDeviceFormatProperties), allocation failure.
  static Expected<Image> create(Context& context, const ImageCreateInfo& info);

  Image() = default;
  ~Image();
  Image(Image&& other) noexcept;
  Image& operator=(Image&& other) noexcept;
  Image(const Image&) = delete;
  Image& operator=(const Image&) = delete;

  bool valid() const noexcept { return image_ != VK_NULL_HANDLE; }
  VkImage handle() const noexcept { return image_; }
  VkImageView view() const noexcept { return view_; }
  VkFormat format() const noexcept { return format_; }
  VkImageAspectFlags aspect() const noexcept { return aspect_; }
  std::uint32_t width() const noexcept { return width_; }
  std::uint32_t height() const noexcept { return height_; }
  VkExtent2D extent() const noexcept { return {width_, height_}; }
  const std::string& name() const noexcept { return name_; }
  VkImageLayout layout() const noexcept { return layout_; }

  // Full barrier (ALL_COMMANDS, MEMORY_READ|WRITE on both sides) to `new_layout`.
  // Conservative and always correct; use the explicit overload on hot paths.
  void transition(VkCommandBuffer cmd, VkImageLayout new_layout);
  void transition(VkCommandBuffer cmd, VkImageLayout new_layout, VkPipelineStageFlags2 src_stage,
                  VkAccessFlags2 src_access, VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access);

  // Records a copy of the whole image (colour or depth aspect) into `dst` at offset 0,
  // tightly packed rows; leaves the image in TRANSFER_SRC_OPTIMAL. `dst` must hold
  // width*height*texel bytes (checked: returns an error without recording).
  Status record_copy_to_buffer(VkCommandBuffer cmd, VkBuffer dst, VkDeviceSize dst_size);

 private:
  void destroy() noexcept;

  Context* context_{nullptr};
  VkImage image_{VK_NULL_HANDLE};
  VkDeviceMemory memory_{VK_NULL_HANDLE};
  VkImageView view_{VK_NULL_HANDLE};
  VkFormat format_{VK_FORMAT_UNDEFINED};
  VkImageAspectFlags aspect_{0};
  std::uint32_t width_{0};
  std::uint32_t height_{0};
  VkImageLayout layout_{VK_IMAGE_LAYOUT_UNDEFINED};
  std::string name_;
};

// Formats of OffscreenTarget, for pipelines that render into it.
inline constexpr VkFormat kOffscreenColorFormat = VK_FORMAT_R8G8B8A8_UNORM;
inline constexpr VkFormat kOffscreenDepthFormat = VK_FORMAT_D32_SFLOAT;

struct ClearValues {
  float color[4]{0.0f, 0.0f, 0.0f, 1.0f};  // linear RGBA in [0, 1]
  float depth{1.0f};                      // far plane (depth compare LESS / LESS_OR_EQUAL)
};

class OffscreenTarget {
 public:
  // colour: RGBA8 UNORM, usage COLOR_ATTACHMENT | STORAGE | SAMPLED | TRANSFER_SRC/DST;
  // depth: D32_SFLOAT, usage DEPTH_STENCIL_ATTACHMENT | SAMPLED | TRANSFER_SRC/DST.
  static Expected<OffscreenTarget> create(Context& context, std::uint32_t width, std::uint32_t height,
                                          const std::string& name = "offscreen");

  OffscreenTarget() = default;

  Image& color() noexcept { return color_; }
  Image& depth() noexcept { return depth_; }
  const Image& color() const noexcept { return color_; }
  const Image& depth() const noexcept { return depth_; }
  std::uint32_t width() const noexcept { return color_.width(); }
  std::uint32_t height() const noexcept { return color_.height(); }
  VkExtent2D extent() const noexcept { return color_.extent(); }

  // Begins dynamic rendering into colour + depth (transitions both to attachment
  // layouts). With `clear` the attachments are cleared to `values`, else loaded.
  // Also sets the viewport (full target, depth 0..1) and scissor.
  void begin_rendering(VkCommandBuffer cmd, bool clear, const ClearValues& values = {});
  void end_rendering(VkCommandBuffer cmd);

  // Clears both attachments with transfer clears (outside rendering).
  void record_clear(VkCommandBuffer cmd, const ClearValues& values);

  // Copies the colour image to a host buffer and returns it as an image (blocking:
  // submits and waits). The caller must have submitted the work that wrote it.
  Expected<ImageRGBA8> read_color(Context& context);
  // Depth values (width*height floats, row-major, top row first); blocking.
  Expected<std::vector<float>> read_depth(Context& context);
  // read_color() + gauss::write_png.
  Status write_color_png(Context& context, const std::filesystem::path& path);

 private:
  Image color_;
  Image depth_;
};

}  // namespace gauss::vk
