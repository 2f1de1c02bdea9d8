// Swapchains: kSwapchainImageCount VkImages with their own memory on the app's device,
// handed out round-robin with the spec's acquire -> wait -> release order.
//
// Layout contract (XR_KHR_vulkan_enable2): after xrWaitSwapchainImage an image is in
// COLOR_ATTACHMENT_OPTIMAL (colour) or DEPTH_STENCIL_ATTACHMENT_OPTIMAL (depth), and the
// app returns it in that layout. New images are UNDEFINED, so the runtime moves them there
// once, at the swapchain's first xrAcquireSwapchainImage: that is one of the few functions
// allowed to use the app's queue (xrCreateSwapchain is not).
#include <cstdlib>
#include <string>
#include <vector>

#include "entry_points.h"
#include "runtime.h"
#include "xr_util.h"

namespace gauss::xr_headless {
namespace {

constexpr VkFormat kFormats[] = {VK_FORMAT_R8G8B8A8_UNORM, VK_FORMAT_R8G8B8A8_SRGB, VK_FORMAT_B8G8R8A8_UNORM,
                                 VK_FORMAT_D32_SFLOAT};
// GAUSS_XR_HEADLESS_ONLY_BGRA=1 plays a runtime whose only colour format is B8G8R8A8_UNORM
// (read at each call), so an app's handling of a format it cannot use can be tested.
std::vector<VkFormat> offered_formats() {
  const char* env = std::getenv("GAUSS_XR_HEADLESS_ONLY_BGRA");
  if (env != nullptr && std::string(env) == "1") return {VK_FORMAT_B8G8R8A8_UNORM, VK_FORMAT_D32_SFLOAT};
  return std::vector<VkFormat>(std::begin(kFormats), std::end(kFormats));
}

VkImageLayout attachment_layout(const Swapchain& sc) {
  return sc.depth ? VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL : VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
}

// The swapchain's session if it is usable, else the error to return.
XrResult session_of(const Swapchain& sc, Session** out) {
  *out = runtime().sessions.find(sc.session_id);
  if (*out == nullptr) return XR_ERROR_HANDLE_INVALID;
  return session_health(**out);
}

Status initialize_layouts(VulkanDevice& vk, const Swapchain& sc) {
  return vk.submit_and_wait(
      [&](VkCommandBuffer cmd) {
        std::vector<VkImageMemoryBarrier> barriers;
        for (VkImage image : sc.images) {
          VkImageMemoryBarrier b{};
          b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
          b.srcAccessMask = 0;
          b.dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
          b.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
          b.newLayout = attachment_layout(sc);
          b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
          b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
          b.image = image;
          b.subresourceRange = {VkImageAspectFlags(sc.depth ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT), 0,
                                VK_REMAINING_MIP_LEVELS, 0, VK_REMAINING_ARRAY_LAYERS};
          barriers.push_back(b);
        }
        vk.vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 0, nullptr, 0,
                                nullptr, static_cast<std::uint32_t>(barriers.size()), barriers.data());
      },
      "swapchain layout initialization");
}

}  // namespace

XrResult xrEnumerateSwapchainFormats(XrSession session, uint32_t capacity, uint32_t* count, int64_t* formats) {
  const auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  const std::vector<VkFormat> offered = offered_formats();
  const XrResult r = two_call("xrEnumerateSwapchainFormats", capacity, count, formats == nullptr,
                              static_cast<std::uint32_t>(offered.size()), [&](std::uint32_t i) {
                                formats[i] = offered[i];
                                return XR_SUCCESS;
                              });
  return XR_FAILED(r) ? r : with_health(*s, r);
}

XrResult xrCreateSwapchain(XrSession session, const XrSwapchainCreateInfo* create_info, XrSwapchain* swapchain) {
  const char* fn = "xrCreateSwapchain";
  const auto lock = lock_runtime();
  Session* s = find(session);
  if (s == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (const XrResult h = session_health(*s); XR_FAILED(h)) return h;
  if (!typed(create_info, XR_TYPE_SWAPCHAIN_CREATE_INFO) || swapchain == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "createInfo must be an XrSwapchainCreateInfo and swapchain non-null");
  const XrSwapchainCreateInfo& ci = *create_info;
  if (ci.createFlags != 0)
    return fail(XR_ERROR_FEATURE_UNSUPPORTED, fn, "protected-content and static-image swapchains are not supported");
  const auto format = static_cast<VkFormat>(ci.format);
  const std::vector<VkFormat> offered = offered_formats();
  if (std::find(offered.begin(), offered.end(), format) == offered.end() || ci.format != int64_t(format))
    return fail(XR_ERROR_SWAPCHAIN_FORMAT_UNSUPPORTED, fn, "format " + std::to_string(ci.format) + " is not offered");
  if (ci.sampleCount != 1) return fail(XR_ERROR_FEATURE_UNSUPPORTED, fn, "only sampleCount 1 is supported");
  if (ci.faceCount != 1) return fail(XR_ERROR_FEATURE_UNSUPPORTED, fn, "only faceCount 1 is supported");
  if (ci.width == 0 || ci.height == 0 || ci.width > 4096 || ci.height > 4096 || ci.arraySize == 0 || ci.mipCount == 0)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "width/height must be 1..4096, arraySize and mipCount >= 1");
  const bool depth = format == VK_FORMAT_D32_SFLOAT;
  VkImageUsageFlags usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
  usage |= depth ? VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT : VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
  if (ci.usageFlags & XR_SWAPCHAIN_USAGE_UNORDERED_ACCESS_BIT) usage |= VK_IMAGE_USAGE_STORAGE_BIT;
  if ((ci.usageFlags & XR_SWAPCHAIN_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT) && !depth)
    return fail(XR_ERROR_FEATURE_UNSUPPORTED, fn, "depth-stencil usage needs a depth format");
  if ((ci.usageFlags & XR_SWAPCHAIN_USAGE_COLOR_ATTACHMENT_BIT) && depth)
    return fail(XR_ERROR_FEATURE_UNSUPPORTED, fn, "colour-attachment usage needs a colour format");
  VkImageCreateFlags flags = (ci.usageFlags & XR_SWAPCHAIN_USAGE_MUTABLE_FORMAT_BIT) ? VK_IMAGE_CREATE_MUTABLE_FORMAT_BIT : 0;

  VulkanDevice& vk = *s->vk;
  // Ask first, so an unsupported combination (e.g. storage on an sRGB format) is a clear
  // OpenXR error rather than a Vulkan validation error.
  VkImageFormatProperties props{};
  if (vk.vkGetPhysicalDeviceImageFormatProperties(vk.physical_device, format, VK_IMAGE_TYPE_2D, VK_IMAGE_TILING_OPTIMAL,
                                                  usage, flags, &props) != VK_SUCCESS ||
      props.maxExtent.width < ci.width || props.maxExtent.height < ci.height || props.maxArrayLayers < ci.arraySize ||
      props.maxMipLevels < ci.mipCount)
    return fail(XR_ERROR_FEATURE_UNSUPPORTED, fn, "the Vulkan device cannot make such images (format, usage or size)");

  auto sc = std::make_unique<Swapchain>();
  sc->session_id = to_id(session);
  sc->info = ci;
  sc->info.next = nullptr;
  sc->format = format;
  sc->depth = depth;
  const std::uint64_t id = runtime().swapchains.insert(std::move(sc));
  Swapchain& chain = *runtime().swapchains.find(id);
  for (std::uint32_t i = 0; i < kSwapchainImageCount; ++i) {
    VkImageCreateInfo ii{};
    ii.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    ii.flags = flags;
    ii.imageType = VK_IMAGE_TYPE_2D;
    ii.format = format;
    ii.extent = {ci.width, ci.height, 1};
    ii.mipLevels = ci.mipCount;
    ii.arrayLayers = ci.arraySize;
    ii.samples = VK_SAMPLE_COUNT_1_BIT;
    ii.tiling = VK_IMAGE_TILING_OPTIMAL;
    ii.usage = usage;
    ii.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    ii.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    VkImage image = VK_NULL_HANDLE;
    VkResult r = vk.vkCreateImage(vk.device, &ii, nullptr, &image);
    if (r != VK_SUCCESS) {
      destroy_swapchain(id);
      return fail(XR_ERROR_RUNTIME_FAILURE, fn, "vkCreateImage: " + vk_result_name(r));
    }
    chain.images.push_back(image);
    VkMemoryRequirements req{};
    vk.vkGetImageMemoryRequirements(vk.device, image, &req);
    auto type = vk.memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    if (!type) type = vk.memory_type(req.memoryTypeBits, 0);
    VkMemoryAllocateInfo ai{};
    ai.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    ai.allocationSize = req.size;
    ai.memoryTypeIndex = type ? *type : 0;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    r = type ? vk.vkAllocateMemory(vk.device, &ai, nullptr, &memory) : VK_ERROR_OUT_OF_DEVICE_MEMORY;
    if (r == VK_SUCCESS) chain.memory.push_back(memory);
    if (r == VK_SUCCESS) r = vk.vkBindImageMemory(vk.device, image, memory, 0);
    if (r != VK_SUCCESS) {
      destroy_swapchain(id);
      return fail(XR_ERROR_RUNTIME_FAILURE, fn, "allocating swapchain image memory: " + vk_result_name(r));
    }
  }
  *swapchain = to_handle<XrSwapchain>(id);
  return with_health(*s, XR_SUCCESS);
}

void destroy_swapchain(std::uint64_t swapchain_id) {
  Runtime& rt = runtime();
  Swapchain* sc = rt.swapchains.find(swapchain_id);
  if (sc == nullptr) return;
  // The app must not destroy a swapchain its GPU work still uses (spec), so nothing is
  // waited for here; the runtime's own submissions are always finished already.
  if (Session* s = rt.sessions.find(sc->session_id)) {
    VulkanDevice& vk = *s->vk;
    for (VkImage image : sc->images) vk.vkDestroyImage(vk.device, image, nullptr);
    for (VkDeviceMemory memory : sc->memory) vk.vkFreeMemory(vk.device, memory, nullptr);
  }
  rt.swapchains.remove(swapchain_id);
}

XrResult xrDestroySwapchain(XrSwapchain swapchain) {
  const auto lock = lock_runtime();
  if (find(swapchain) == nullptr) return XR_ERROR_HANDLE_INVALID;
  destroy_swapchain(to_id(swapchain));
  return XR_SUCCESS;
}

XrResult xrEnumerateSwapchainImages(XrSwapchain swapchain, uint32_t capacity, uint32_t* count,
                                    XrSwapchainImageBaseHeader* images) {
  const char* fn = "xrEnumerateSwapchainImages";
  const auto lock = lock_runtime();
  Swapchain* sc = find(swapchain);
  if (sc == nullptr) return XR_ERROR_HANDLE_INVALID;
  Session* s = nullptr;
  if (const XrResult h = session_of(*sc, &s); XR_FAILED(h)) return h;
  auto* vk_images = reinterpret_cast<XrSwapchainImageVulkan2KHR*>(images);
  const XrResult r = two_call(fn, capacity, count, images == nullptr, static_cast<std::uint32_t>(sc->images.size()),
                              [&](std::uint32_t i) {
                                if (vk_images[i].type != XR_TYPE_SWAPCHAIN_IMAGE_VULKAN2_KHR)
                                  return fail(XR_ERROR_VALIDATION_FAILURE, fn,
                                              "images[" + std::to_string(i) + "] is not an XrSwapchainImageVulkan2KHR");
                                vk_images[i].image = sc->images[i];
                                return XR_SUCCESS;
                              });
  return XR_FAILED(r) ? r : with_health(*s, r);
}

XrResult xrAcquireSwapchainImage(XrSwapchain swapchain, const XrSwapchainImageAcquireInfo* info, uint32_t* index) {
  const char* fn = "xrAcquireSwapchainImage";
  const auto lock = lock_runtime();
  Swapchain* sc = find(swapchain);
  if (sc == nullptr) return XR_ERROR_HANDLE_INVALID;
  Session* s = nullptr;
  if (const XrResult h = session_of(*sc, &s); XR_FAILED(h)) return h;
  if ((info != nullptr && info->type != XR_TYPE_SWAPCHAIN_IMAGE_ACQUIRE_INFO) || index == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "acquireInfo must be null or an XrSwapchainImageAcquireInfo, index non-null");
  const std::size_t held = sc->acquired.size() + (sc->waited ? 1 : 0);
  if (held >= sc->images.size())
    return fail(XR_ERROR_CALL_ORDER_INVALID, fn, "every image is acquired and not yet released");
  if (!sc->layouts_initialized) {
    if (auto st = initialize_layouts(*s->vk, *sc); !st) return fail(XR_ERROR_RUNTIME_FAILURE, fn, st.message());
    sc->layouts_initialized = true;
  }
  *index = sc->next_index;
  sc->acquired.push_back(sc->next_index);
  sc->next_index = (sc->next_index + 1) % static_cast<std::uint32_t>(sc->images.size());
  return with_health(*s, XR_SUCCESS);
}

XrResult xrWaitSwapchainImage(XrSwapchain swapchain, const XrSwapchainImageWaitInfo* info) {
  const char* fn = "xrWaitSwapchainImage";
  const auto lock = lock_runtime();
  Swapchain* sc = find(swapchain);
  if (sc == nullptr) return XR_ERROR_HANDLE_INVALID;
  Session* s = nullptr;
  if (const XrResult h = session_of(*sc, &s); XR_FAILED(h)) return h;
  if (!typed(info, XR_TYPE_SWAPCHAIN_IMAGE_WAIT_INFO))
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "waitInfo must be an XrSwapchainImageWaitInfo");
  if (sc->waited) return fail(XR_ERROR_CALL_ORDER_INVALID, fn, "the previously waited image is not released yet");
  if (sc->acquired.empty()) return fail(XR_ERROR_CALL_ORDER_INVALID, fn, "no image is acquired");
  // Images are never busy on the runtime's side (it waits for its own work), so no timeout.
  sc->waited = sc->acquired.front();
  sc->acquired.pop_front();
  return with_health(*s, XR_SUCCESS);
}

XrResult xrReleaseSwapchainImage(XrSwapchain swapchain, const XrSwapchainImageReleaseInfo* info) {
  const char* fn = "xrReleaseSwapchainImage";
  const auto lock = lock_runtime();
  Swapchain* sc = find(swapchain);
  if (sc == nullptr) return XR_ERROR_HANDLE_INVALID;
  Session* s = nullptr;
  if (const XrResult h = session_of(*sc, &s); XR_FAILED(h)) return h;
  if (info != nullptr && info->type != XR_TYPE_SWAPCHAIN_IMAGE_RELEASE_INFO)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "releaseInfo must be null or an XrSwapchainImageReleaseInfo");
  if (!sc->waited) return fail(XR_ERROR_CALL_ORDER_INVALID, fn, "no image has been waited on (acquire and wait first)");
  sc->last_released = sc->waited;
  sc->waited.reset();
  return with_health(*s, XR_SUCCESS);
}

}  // namespace gauss::xr_headless
