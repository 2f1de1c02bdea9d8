#pragma once
// The runtime's own Vulkan use on the application's device: swapchain images, their first
// layout transition, and the readback of captured frames. Every function comes from the
// application's vkGetInstanceProcAddr (vkGetDeviceProcAddr for device functions), so the
// calls pass through the app's layers (validation sees them) and nothing clashes with the
// app's loader. The queue is the app's; the runtime submits on it only from the functions
// the spec lets touch it (xrAcquireSwapchainImage, xrEndFrame) and waits for its own work
// with a fence before returning, so the app never has to know about it.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "gauss/engine/result.h"
#include "xr_headers.h"

namespace gauss::xr_headless {

#define GAUSS_XR_HEADLESS_INSTANCE_FUNCTIONS(X) \
  X(vkGetDeviceProcAddr)                        \
  X(vkEnumeratePhysicalDevices)                 \
  X(vkGetPhysicalDeviceMemoryProperties)        \
  X(vkGetPhysicalDeviceImageFormatProperties)

#define GAUSS_XR_HEADLESS_DEVICE_FUNCTIONS(X) \
  X(vkGetDeviceQueue)                         \
  X(vkCreateImage)                            \
  X(vkDestroyImage)                           \
  X(vkGetImageMemoryRequirements)             \
  X(vkBindImageMemory)                        \
  X(vkCreateBuffer)                           \
  X(vkDestroyBuffer)                          \
  X(vkGetBufferMemoryRequirements)            \
  X(vkBindBufferMemory)                       \
  X(vkAllocateMemory)                         \
  X(vkFreeMemory)                             \
  X(vkMapMemory)                              \
  X(vkUnmapMemory)                            \
  X(vkInvalidateMappedMemoryRanges)           \
  X(vkCreateCommandPool)                      \
  X(vkDestroyCommandPool)                     \
  X(vkAllocateCommandBuffers)                 \
  X(vkResetCommandBuffer)                     \
  X(vkBeginCommandBuffer)                     \
  X(vkEndCommandBuffer)                       \
  X(vkCmdPipelineBarrier)                     \
  X(vkCmdCopyImageToBuffer)                   \
  X(vkCreateFence)                            \
  X(vkDestroyFence)                           \
  X(vkResetFences)                            \
  X(vkWaitForFences)                          \
  X(vkQueueSubmit)                            \
  X(vkQueueWaitIdle)

struct VulkanDevice {
  VkInstance instance{VK_NULL_HANDLE};
  VkPhysicalDevice physical_device{VK_NULL_HANDLE};
  VkDevice device{VK_NULL_HANDLE};
  std::uint32_t queue_family{0};
  VkQueue queue{VK_NULL_HANDLE};
  VkCommandPool pool{VK_NULL_HANDLE};
  VkCommandBuffer cmd{VK_NULL_HANDLE};
  VkFence fence{VK_NULL_HANDLE};

#define GAUSS_XR_HEADLESS_MEMBER(name) PFN_##name name{nullptr};
  GAUSS_XR_HEADLESS_INSTANCE_FUNCTIONS(GAUSS_XR_HEADLESS_MEMBER)
  GAUSS_XR_HEADLESS_DEVICE_FUNCTIONS(GAUSS_XR_HEADLESS_MEMBER)
#undef GAUSS_XR_HEADLESS_MEMBER

  VulkanDevice() = default;
  VulkanDevice(const VulkanDevice&) = delete;
  VulkanDevice& operator=(const VulkanDevice&) = delete;

  // Destroys the runtime's pool and fence (never the app's objects). Explicit, not a
  // destructor, so nothing calls Vulkan during static destruction at exit.
  void destroy();

  // Records with `record` into the runtime's command buffer, submits it on the app's
  // queue and waits for it. Only for functions allowed to access the queue.
  Status submit_and_wait(const std::function<void(VkCommandBuffer)>& record, const char* what);
  // A memory type index among `type_bits` with `flags`, or an error.
  Expected<std::uint32_t> memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags flags) const;
};

// Loads the functions and makes the runtime's command pool and fence on the app's device.
Expected<std::unique_ptr<VulkanDevice>> open_vulkan_device(PFN_vkGetInstanceProcAddr get_instance_proc_addr,
                                                           const XrGraphicsBindingVulkan2KHR& binding);

// libvulkan's own vkGetInstanceProcAddr, for a VkInstance the app made without
// xrCreateVulkanInstanceKHR: the app has a VkInstance, so a Vulkan loader is already in
// the process; nullptr if none is.
PFN_vkGetInstanceProcAddr loaded_vulkan_get_instance_proc_addr();

// "VK_ERROR_OUT_OF_DEVICE_MEMORY" etc., or the number.
std::string vk_result_name(VkResult r);

}  // namespace gauss::xr_headless
