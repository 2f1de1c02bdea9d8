// Swapchain: surface format / present mode / extent choice, per-image views and
// render-finished semaphores, per-slot acquire semaphores, acquire, submit + present,
// recreation. The rules are in vk_swapchain.h.
#include "gauss/render/vk_swapchain.h"

#include <algorithm>
#include <string>
#include <vector>

#include "gauss/render/vk_check.h"
#include "gauss/render/vk_context.h"

namespace gauss::vk {
namespace {

constexpr std::uint32_t kMaxFramesInFlight = 8;

VkPresentModeKHR to_vk(PresentMode mode) {
  switch (mode) {
    case PresentMode::mailbox: return VK_PRESENT_MODE_MAILBOX_KHR;
    case PresentMode::immediate: return VK_PRESENT_MODE_IMMEDIATE_KHR;
    case PresentMode::fifo: break;
  }
  return VK_PRESENT_MODE_FIFO_KHR;
}

// The preference order of the header comment: UNORM first (our bytes are already
// display-encoded), sRGB formats only as a fallback.
int format_rank(const VkSurfaceFormatKHR& f) {
  if (f.colorSpace != VK_COLOR_SPACE_SRGB_NONLINEAR_KHR) return 0;
  switch (f.format) {
    case VK_FORMAT_B8G8R8A8_UNORM: return 4;
    case VK_FORMAT_R8G8B8A8_UNORM: return 3;
    case VK_FORMAT_B8G8R8A8_SRGB: return 2;
    case VK_FORMAT_R8G8B8A8_SRGB: return 1;
    default: return 0;
  }
}

template <class Fn>
Fn instance_fn(VkInstance instance, const char* name) {
  return reinterpret_cast<Fn>(vkGetInstanceProcAddr(instance, name));
}
template <class Fn>
Fn device_fn(VkDevice device, const char* name) {
  return reinterpret_cast<Fn>(vkGetDeviceProcAddr(device, name));
}

VkSemaphore make_semaphore(Context& ctx, const std::string& name, Status& status) {
  VkSemaphoreCreateInfo sci{};
  sci.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
  VkSemaphore s = VK_NULL_HANDLE;
  if (const VkResult r = vkCreateSemaphore(ctx.device(), &sci, nullptr, &s); r != VK_SUCCESS) {
    status = result_error(r, "vkCreateSemaphore", __FILE__, __LINE__);
    return VK_NULL_HANDLE;
  }
  ctx.set_debug_name(VK_OBJECT_TYPE_SEMAPHORE, reinterpret_cast<std::uint64_t>(s), name.c_str());
  return s;
}

}  // namespace

const char* present_mode_name(PresentMode mode) noexcept {
  switch (mode) {
    case PresentMode::mailbox: return "mailbox";
    case PresentMode::immediate: return "immediate";
    case PresentMode::fifo: break;
  }
  return "fifo";
}

Expected<std::unique_ptr<Swapchain>> Swapchain::create(Context& context, const SwapchainCreateInfo& info) {
  if (context.surface() == VK_NULL_HANDLE) {
    return Error{"Swapchain: the context has no surface (set ContextCreateInfo::create_surface)"};
  }
  if (info.frames_in_flight == 0 || info.frames_in_flight > kMaxFramesInFlight) {
    return Error{"Swapchain: frames_in_flight " + std::to_string(info.frames_in_flight) + " outside 1.." +
                 std::to_string(kMaxFramesInFlight)};
  }
  std::unique_ptr<Swapchain> sc(new Swapchain());
  sc->context_ = &context;
  sc->requested_mode_ = info.present_mode;
  Functions& f = sc->fn_;
  const VkInstance inst = context.instance();
  const VkDevice dev = context.device();
  f.get_capabilities = instance_fn<PFN_vkGetPhysicalDeviceSurfaceCapabilitiesKHR>(
      inst, "vkGetPhysicalDeviceSurfaceCapabilitiesKHR");
  f.get_formats = instance_fn<PFN_vkGetPhysicalDeviceSurfaceFormatsKHR>(inst, "vkGetPhysicalDeviceSurfaceFormatsKHR");
  f.get_present_modes =
      instance_fn<PFN_vkGetPhysicalDeviceSurfacePresentModesKHR>(inst, "vkGetPhysicalDeviceSurfacePresentModesKHR");
  f.create = device_fn<PFN_vkCreateSwapchainKHR>(dev, "vkCreateSwapchainKHR");
  f.destroy = device_fn<PFN_vkDestroySwapchainKHR>(dev, "vkDestroySwapchainKHR");
  f.get_images = device_fn<PFN_vkGetSwapchainImagesKHR>(dev, "vkGetSwapchainImagesKHR");
  f.acquire = device_fn<PFN_vkAcquireNextImageKHR>(dev, "vkAcquireNextImageKHR");
  f.present = device_fn<PFN_vkQueuePresentKHR>(dev, "vkQueuePresentKHR");
  if (!f.get_capabilities || !f.get_formats || !f.get_present_modes) {
    return Error{"Swapchain: VK_KHR_surface functions are unavailable (enable the extensions of "
                 "glfwGetRequiredInstanceExtensions() in ContextCreateInfo::instance_extensions)"};
  }
  if (!f.create || !f.destroy || !f.get_images || !f.acquire || !f.present) {
    return Error{"Swapchain: VK_KHR_swapchain functions are unavailable (add VK_KHR_swapchain to "
                 "ContextCreateInfo::device_extensions)"};
  }
  for (std::uint32_t i = 0; i < info.frames_in_flight; ++i) {
    Status st = Ok{};
    VkSemaphore s = make_semaphore(context, "swapchain acquire slot " + std::to_string(i), st);
    if (!st) return st.error();
    sc->acquire_semaphores_.push_back(s);
  }
  if (auto st = sc->build(info.extent); !st) return st.error();
  return sc;
}

Swapchain::~Swapchain() {
  if (context_ == nullptr) return;
  // Destruction cannot report an error: a lost device is printed by the context later.
  (void)vkQueueWaitIdle(context_->queue());
  destroy_images();
  for (VkSemaphore s : acquire_semaphores_) vkDestroySemaphore(context_->device(), s, nullptr);
}

void Swapchain::destroy_images() noexcept {
  const VkDevice dev = context_->device();
  for (VkImageView v : views_) vkDestroyImageView(dev, v, nullptr);
  for (VkSemaphore s : render_finished_) vkDestroySemaphore(dev, s, nullptr);
  views_.clear();
  render_finished_.clear();
  images_.clear();
  if (swapchain_ != VK_NULL_HANDLE) fn_.destroy(dev, swapchain_, nullptr);
  swapchain_ = VK_NULL_HANDLE;
}

Status Swapchain::recreate(VkExtent2D extent) {
  if (acquired_) return Error{"Swapchain::recreate: an acquired image was not submitted yet"};
  // The one wait on the frame path (header comment): every frame that used the old
  // images and semaphores is finished after this.
  GAUSS_VK_TRY(vkQueueWaitIdle(context_->queue()));
  ++generation_;
  return build(extent);
}

Status Swapchain::build(VkExtent2D wanted) {
  Context& ctx = *context_;
  const VkPhysicalDevice pd = ctx.physical_device();
  const VkSurfaceKHR surface = ctx.surface();
  VkSwapchainKHR old = swapchain_;
  // Views and semaphores of the old images go now (the queue is idle, see recreate());
  // the old swapchain itself is handed to vkCreateSwapchainKHR, then destroyed.
  {
    const VkDevice dev = ctx.device();
    for (VkImageView v : views_) vkDestroyImageView(dev, v, nullptr);
    for (VkSemaphore s : render_finished_) vkDestroySemaphore(dev, s, nullptr);
    views_.clear();
    render_finished_.clear();
    images_.clear();
  }
  swapchain_ = VK_NULL_HANDLE;
  extent_ = {0, 0};
  needs_recreate_ = false;

  VkSurfaceCapabilitiesKHR caps{};
  GAUSS_VK_TRY(fn_.get_capabilities(pd, surface, &caps));
  VkExtent2D extent = caps.currentExtent;
  if (extent.width == 0xFFFFFFFFu) {
    extent.width = std::clamp(wanted.width, caps.minImageExtent.width, caps.maxImageExtent.width);
    extent.height = std::clamp(wanted.height, caps.minImageExtent.height, caps.maxImageExtent.height);
  }
  if (wanted.width == 0 || wanted.height == 0 || extent.width == 0 || extent.height == 0) {
    // Minimised: no images until a size comes back.
    if (old != VK_NULL_HANDLE) fn_.destroy(ctx.device(), old, nullptr);
    return Ok{};
  }

  std::uint32_t count = 0;
  GAUSS_VK_TRY(fn_.get_formats(pd, surface, &count, nullptr));
  std::vector<VkSurfaceFormatKHR> formats(count);
  GAUSS_VK_TRY(fn_.get_formats(pd, surface, &count, formats.data()));
  if (formats.empty()) return Error{"Swapchain: the surface offers no formats"};
  const VkSurfaceFormatKHR chosen = *std::max_element(
      formats.begin(), formats.end(),
      [](const VkSurfaceFormatKHR& a, const VkSurfaceFormatKHR& b) { return format_rank(a) < format_rank(b); });

  GAUSS_VK_TRY(fn_.get_present_modes(pd, surface, &count, nullptr));
  std::vector<VkPresentModeKHR> modes(count);
  GAUSS_VK_TRY(fn_.get_present_modes(pd, surface, &count, modes.data()));
  const bool offered = std::find(modes.begin(), modes.end(), to_vk(requested_mode_)) != modes.end();
  present_mode_ = offered ? requested_mode_ : PresentMode::fifo;

  // TRANSFER_DST: the scene is blitted in; COLOR_ATTACHMENT: the UI is drawn on top;
  // TRANSFER_SRC (when offered): screenshots read the image back.
  const VkImageUsageFlags required = VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
  if ((caps.supportedUsageFlags & required) != required) {
    return Error{"Swapchain: the surface does not support TRANSFER_DST + COLOR_ATTACHMENT images"};
  }
  usage_ = required | (caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_SRC_BIT);

  // One image more than the minimum, so acquire rarely waits for the display.
  std::uint32_t image_count = caps.minImageCount + 1;
  if (caps.maxImageCount > 0) image_count = std::min(image_count, caps.maxImageCount);

  VkSwapchainCreateInfoKHR sci{};
  sci.sType = VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR;
  sci.surface = surface;
  sci.minImageCount = image_count;
  sci.imageFormat = chosen.format;
  sci.imageColorSpace = chosen.colorSpace;
  sci.imageExtent = extent;
  sci.imageArrayLayers = 1;
  sci.imageUsage = usage_;
  sci.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
  sci.preTransform = caps.currentTransform;
  sci.compositeAlpha = (caps.supportedCompositeAlpha & VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR)
                           ? VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR
                           : static_cast<VkCompositeAlphaFlagBitsKHR>(
                                 caps.supportedCompositeAlpha & (~caps.supportedCompositeAlpha + 1));
  sci.presentMode = to_vk(present_mode_);
  sci.clipped = VK_TRUE;
  sci.oldSwapchain = old;
  const VkResult created = fn_.create(ctx.device(), &sci, nullptr, &swapchain_);
  if (old != VK_NULL_HANDLE) fn_.destroy(ctx.device(), old, nullptr);
  if (created != VK_SUCCESS) {
    swapchain_ = VK_NULL_HANDLE;
    return result_error(created, "vkCreateSwapchainKHR", __FILE__, __LINE__);
  }
  format_ = chosen.format;
  color_space_ = chosen.colorSpace;
  extent_ = extent;

  GAUSS_VK_TRY(fn_.get_images(ctx.device(), swapchain_, &count, nullptr));
  images_.resize(count);
  GAUSS_VK_TRY(fn_.get_images(ctx.device(), swapchain_, &count, images_.data()));
  for (std::uint32_t i = 0; i < count; ++i) {
    const std::string name = "swapchain image " + std::to_string(i);
    ctx.set_debug_name(VK_OBJECT_TYPE_IMAGE, reinterpret_cast<std::uint64_t>(images_[i]), name.c_str());
    VkImageViewCreateInfo vci{};
    vci.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
    vci.image = images_[i];
    vci.viewType = VK_IMAGE_VIEW_TYPE_2D;
    vci.format = format_;
    vci.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    VkImageView view = VK_NULL_HANDLE;
    GAUSS_VK_TRY(vkCreateImageView(ctx.device(), &vci, nullptr, &view));
    views_.push_back(view);
    Status st = Ok{};
    VkSemaphore s = make_semaphore(ctx, "swapchain render finished " + std::to_string(i), st);
    if (!st) return st;
    render_finished_.push_back(s);
  }
  return Ok{};
}

Expected<Swapchain::Acquired> Swapchain::acquire(std::uint32_t frame_slot) {
  if (frame_slot >= acquire_semaphores_.size()) {
    return Error{"Swapchain::acquire: frame slot " + std::to_string(frame_slot) + " >= frames_in_flight " +
                 std::to_string(acquire_semaphores_.size())};
  }
  if (acquired_) return Error{"Swapchain::acquire: the previous acquired image was not submitted"};
  if (swapchain_ == VK_NULL_HANDLE) return Acquired{AcquireStatus::skip, 0};
  std::uint32_t index = 0;
  const VkResult r = fn_.acquire(context_->device(), swapchain_, UINT64_MAX, acquire_semaphores_[frame_slot],
                                 VK_NULL_HANDLE, &index);
  if (r == VK_ERROR_OUT_OF_DATE_KHR) {
    needs_recreate_ = true;
    return Acquired{AcquireStatus::recreate, 0};
  }
  if (r == VK_SUBOPTIMAL_KHR) {
    needs_recreate_ = true;
  } else if (r != VK_SUCCESS) {
    return result_error(r, "vkAcquireNextImageKHR", __FILE__, __LINE__);
  }
  acquired_ = true;
  acquired_image_ = index;
  acquired_slot_ = frame_slot;
  return Acquired{AcquireStatus::acquired, index};
}

Expected<bool> Swapchain::submit_and_present(VkCommandBuffer cmd, VkFence fence) {
  if (!acquired_) return Error{"Swapchain::submit_and_present: no image was acquired"};
  acquired_ = false;

  VkSemaphoreSubmitInfo wait{};
  wait.sType = VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO;
  wait.semaphore = acquire_semaphores_[acquired_slot_];
  wait.stageMask = kAcquireWaitStage;
  VkSemaphoreSubmitInfo signal{};
  signal.sType = VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO;
  signal.semaphore = render_finished_[acquired_image_];
  signal.stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  VkCommandBufferSubmitInfo cbi{};
  cbi.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO;
  cbi.commandBuffer = cmd;
  VkSubmitInfo2 si{};
  si.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2;
  si.waitSemaphoreInfoCount = 1;
  si.pWaitSemaphoreInfos = &wait;
  si.commandBufferInfoCount = cmd != VK_NULL_HANDLE ? 1u : 0u;
  si.pCommandBufferInfos = &cbi;
  si.signalSemaphoreInfoCount = 1;
  si.pSignalSemaphoreInfos = &signal;
  GAUSS_VK_TRY(vkQueueSubmit2(context_->queue(), 1, &si, fence));

  VkPresentInfoKHR pi{};
  pi.sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR;
  pi.waitSemaphoreCount = 1;
  pi.pWaitSemaphores = &render_finished_[acquired_image_];
  pi.swapchainCount = 1;
  pi.pSwapchains = &swapchain_;
  pi.pImageIndices = &acquired_image_;
  const VkResult r = fn_.present(context_->queue(), &pi);
  if (r == VK_SUBOPTIMAL_KHR || r == VK_ERROR_OUT_OF_DATE_KHR) {
    needs_recreate_ = true;
  } else if (r != VK_SUCCESS) {
    return result_error(r, "vkQueuePresentKHR", __FILE__, __LINE__);
  }
  return needs_recreate_;
}

}  // namespace gauss::vk
