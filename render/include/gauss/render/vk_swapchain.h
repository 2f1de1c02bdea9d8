#pragma once
// gauss::vk::Swapchain: the presentable images of the context's window surface
// (ContextCreateInfo::create_surface + VK_KHR_swapchain), the semaphores that pace
// them, and the submit + present of a frame.
//
// Frame protocol (one thread, the display loop; N = frames_in_flight, slot = the
// frame ring's slot index 0..N-1):
//   1. the caller waits for the fence of the frame that last used `slot`;
//   2. acquire(slot)                       -> an image index, or "recreate" (nothing signalled);
//   3. the caller records into its command buffer, including the swapchain image's
//      transition to PRESENT_SRC_KHR, and ends it;
//   4. submit_and_present(cmd, fence)      -> waits the slot's acquire semaphore at the
//      transfer stage (the first use of the image must be a transfer, or a barrier whose
//      source stage includes VK_PIPELINE_STAGE_2_TRANSFER_BIT), signals the image's
//      render-finished semaphore and `fence`, presents.
// Once acquire() has returned an image, that frame must be submitted (an empty command
// buffer will do): an acquire semaphore left signalled could not be reused.
//
// Semaphores: one acquire semaphore per frame slot (free again once the slot's fence
// has signalled, step 1); one render-finished semaphore per swapchain image, not per
// slot: present holds it until the image is acquired again, which a slot's fence does
// not tell (the validation layer reports per-slot reuse as an error).
//
// Format: B8G8R8A8_UNORM, else R8G8B8A8_UNORM, else the _SRGB variants, else the first
// offered (all with SRGB_NONLINEAR colour space). Our renderer writes RGBA8 UNORM images
// whose bytes are already display-encoded (sRGB curve, as the PNGs); a UNORM swapchain
// passes those bytes to the display unchanged. An _SRGB swapchain would encode them a
// second time on every blit or attachment write (washed-out image), so it is only a
// fallback for surfaces without UNORM formats.
//
// Recreation (resize, OUT_OF_DATE, SUBOPTIMAL): recreate() waits for the queue to go idle
// (vkQueueWaitIdle) before destroying the old images' views and semaphores and the old
// swapchain. This is the one wait on the frame path; it happens only when the window
// changes size, and it makes every frame that used the old images finished without the
// swapchain knowing the caller's fences. A 0x0 extent (minimised window) keeps no
// swapchain at all: acquire() then reports "skip" until recreate() gets a size again.
//
// Threading: the context's queue is used without the context's submit lock, so frames
// must be submitted from the one thread that also calls Context::submit*.
#include <cstdint>
#include <memory>
#include <vector>

#include <volk.h>

#include "gauss/engine/result.h"

namespace gauss::vk {

class Context;

enum class PresentMode {
  fifo,       // vsync, never tears; always offered (the default)
  mailbox,    // vsync, newest frame wins; falls back to fifo when not offered
  immediate,  // no vsync, may tear; falls back to fifo when not offered
};

// "fifo", "mailbox", "immediate".
const char* present_mode_name(PresentMode mode) noexcept;

struct SwapchainCreateInfo {
  // Framebuffer size in pixels (glfwGetFramebufferSize). The surface's currentExtent wins
  // when it reports one; otherwise this is clamped to the surface's limits.
  VkExtent2D extent{0, 0};
  PresentMode present_mode{PresentMode::fifo};
  // Acquire semaphores to keep: the number of frames the caller keeps in flight (1..8).
  std::uint32_t frames_in_flight{2};
};

class Swapchain {
 public:
  // Errors: the context has no surface or was made without VK_KHR_swapchain, the queue
  // cannot present, the surface offers no format with TRANSFER_DST + COLOR_ATTACHMENT
  // usage, a failed vkCreate*. A 0x0 extent is not an error (see recreate()).
  static Expected<std::unique_ptr<Swapchain>> create(Context& context, const SwapchainCreateInfo& info);
  // Waits for the queue to go idle, then destroys everything. Must run before the
  // Context is destroyed.
  ~Swapchain();
  Swapchain(const Swapchain&) = delete;
  Swapchain& operator=(const Swapchain&) = delete;

  // Recreates the images for a new framebuffer size (see the header comment: waits for
  // the queue to go idle). 0x0 destroys the images and leaves none until a later call
  // with a size. Errors: as create().
  Status recreate(VkExtent2D extent);

  enum class AcquireStatus {
    acquired,  // image_index is valid; the frame must be submitted
    recreate,  // OUT_OF_DATE: nothing was signalled; recreate() for the current size, retry
    skip,      // no images (0x0 extent): do not render this frame
  };
  struct Acquired {
    AcquireStatus status{AcquireStatus::skip};
    std::uint32_t image_index{0};
  };
  // Acquires the next image, signalling the acquire semaphore of `frame_slot` (must be
  // below frames_in_flight and its previous frame finished). SUBOPTIMAL counts as
  // acquired; needs_recreate() is then true after the present. Errors: a slot out of
  // range, an acquire while a frame is pending submission, device loss.
  Expected<Acquired> acquire(std::uint32_t frame_slot);

  // Submits `cmd` (ended) for the image acquire() returned, waiting that acquire and
  // signalling `fence` (may be null) and the image's render-finished semaphore, then
  // presents it. Returns whether the swapchain should be recreated before the next
  // acquire (SUBOPTIMAL or OUT_OF_DATE from present or acquire). Errors: no acquired
  // image, device loss, a failed submit.
  Expected<bool> submit_and_present(VkCommandBuffer cmd, VkFence fence);

  // True after an acquire/present reported SUBOPTIMAL or OUT_OF_DATE, until recreate().
  bool needs_recreate() const noexcept { return needs_recreate_; }
  // No images: the extent was 0x0 (minimised window).
  bool empty() const noexcept { return swapchain_ == VK_NULL_HANDLE; }

  VkSwapchainKHR handle() const noexcept { return swapchain_; }
  VkFormat format() const noexcept { return format_; }
  VkColorSpaceKHR color_space() const noexcept { return color_space_; }
  VkExtent2D extent() const noexcept { return extent_; }
  PresentMode present_mode() const noexcept { return present_mode_; }
  VkImageUsageFlags usage() const noexcept { return usage_; }
  std::uint32_t image_count() const noexcept { return static_cast<std::uint32_t>(images_.size()); }
  VkImage image(std::uint32_t index) const noexcept { return images_[index]; }
  VkImageView view(std::uint32_t index) const noexcept { return views_[index]; }
  const std::vector<VkImageView>& views() const noexcept { return views_; }
  std::uint32_t frames_in_flight() const noexcept { return static_cast<std::uint32_t>(acquire_semaphores_.size()); }
  // Increases with every recreate(): objects made per image (framebuffers) compare it.
  std::uint64_t generation() const noexcept { return generation_; }
  // The stage submit_and_present() waits the acquire semaphore at.
  static constexpr VkPipelineStageFlags2 kAcquireWaitStage = VK_PIPELINE_STAGE_2_TRANSFER_BIT;

  // WSI functions fetched from the context's instance and device (volk's global pointers
  // may come from an instance without the surface extensions).
  struct Functions {
    PFN_vkGetPhysicalDeviceSurfaceCapabilitiesKHR get_capabilities{nullptr};
    PFN_vkGetPhysicalDeviceSurfaceFormatsKHR get_formats{nullptr};
    PFN_vkGetPhysicalDeviceSurfacePresentModesKHR get_present_modes{nullptr};
    PFN_vkCreateSwapchainKHR create{nullptr};
    PFN_vkDestroySwapchainKHR destroy{nullptr};
    PFN_vkGetSwapchainImagesKHR get_images{nullptr};
    PFN_vkAcquireNextImageKHR acquire{nullptr};
    PFN_vkQueuePresentKHR present{nullptr};
  };

 private:
  Swapchain() = default;
  Status build(VkExtent2D extent);     // creates swapchain, views, render-finished semaphores
  void destroy_images() noexcept;      // views + semaphores (+ the swapchain itself)

  Context* context_{nullptr};
  Functions fn_{};
  PresentMode requested_mode_{PresentMode::fifo};
  PresentMode present_mode_{PresentMode::fifo};
  VkSwapchainKHR swapchain_{VK_NULL_HANDLE};
  VkFormat format_{VK_FORMAT_UNDEFINED};
  VkColorSpaceKHR color_space_{VK_COLOR_SPACE_SRGB_NONLINEAR_KHR};
  VkExtent2D extent_{0, 0};
  VkImageUsageFlags usage_{0};
  std::vector<VkImage> images_;
  std::vector<VkImageView> views_;
  std::vector<VkSemaphore> render_finished_;     // per image
  std::vector<VkSemaphore> acquire_semaphores_;  // per frame slot
  bool acquired_{false};                         // an image is acquired, not yet submitted
  std::uint32_t acquired_image_{0};
  std::uint32_t acquired_slot_{0};
  bool needs_recreate_{false};
  std::uint64_t generation_{0};
};

}  // namespace gauss::vk
