#include "vk_device.h"

#include <dlfcn.h>

namespace gauss::xr_headless {

std::string vk_result_name(VkResult r) {
  switch (r) {
    case VK_SUCCESS: return "VK_SUCCESS";
    case VK_NOT_READY: return "VK_NOT_READY";
    case VK_TIMEOUT: return "VK_TIMEOUT";
    case VK_ERROR_OUT_OF_HOST_MEMORY: return "VK_ERROR_OUT_OF_HOST_MEMORY";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY: return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
    case VK_ERROR_INITIALIZATION_FAILED: return "VK_ERROR_INITIALIZATION_FAILED";
    case VK_ERROR_DEVICE_LOST: return "VK_ERROR_DEVICE_LOST";
    case VK_ERROR_MEMORY_MAP_FAILED: return "VK_ERROR_MEMORY_MAP_FAILED";
    case VK_ERROR_LAYER_NOT_PRESENT: return "VK_ERROR_LAYER_NOT_PRESENT";
    case VK_ERROR_EXTENSION_NOT_PRESENT: return "VK_ERROR_EXTENSION_NOT_PRESENT";
    case VK_ERROR_FEATURE_NOT_PRESENT: return "VK_ERROR_FEATURE_NOT_PRESENT";
    case VK_ERROR_INCOMPATIBLE_DRIVER: return "VK_ERROR_INCOMPATIBLE_DRIVER";
    case VK_ERROR_FORMAT_NOT_SUPPORTED: return "VK_ERROR_FORMAT_NOT_SUPPORTED";
    default: return "VkResult " + std::to_string(static_cast<int>(r));
  }
}

PFN_vkGetInstanceProcAddr loaded_vulkan_get_instance_proc_addr() {
  // RTLD_NOLOAD: only a loader the process already has; the handle is closed again at
  // once, the symbol stays valid as long as the app keeps its loader (and its VkInstance).
  void* lib = dlopen("libvulkan.so.1", RTLD_NOW | RTLD_LOCAL | RTLD_NOLOAD);
  if (lib == nullptr) return nullptr;
  auto fn = reinterpret_cast<PFN_vkGetInstanceProcAddr>(dlsym(lib, "vkGetInstanceProcAddr"));
  dlclose(lib);
  return fn;
}

void VulkanDevice::destroy() {
  // The pool's command buffer is never pending here: every submission was waited for.
  if (pool != VK_NULL_HANDLE) vkDestroyCommandPool(device, pool, nullptr);
  if (fence != VK_NULL_HANDLE) vkDestroyFence(device, fence, nullptr);
  pool = VK_NULL_HANDLE;
  cmd = VK_NULL_HANDLE;
  fence = VK_NULL_HANDLE;
}

Expected<std::uint32_t> VulkanDevice::memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags flags) const {
  VkPhysicalDeviceMemoryProperties props{};
  vkGetPhysicalDeviceMemoryProperties(physical_device, &props);
  for (std::uint32_t i = 0; i < props.memoryTypeCount; ++i)
    if ((type_bits & (1u << i)) != 0 && (props.memoryTypes[i].propertyFlags & flags) == flags) return i;
  return Error{"no Vulkan memory type with the required properties"};
}

Status VulkanDevice::submit_and_wait(const std::function<void(VkCommandBuffer)>& record, const char* what) {
  VkResult r = vkResetCommandBuffer(cmd, 0);
  VkCommandBufferBeginInfo begin{};
  begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  if (r == VK_SUCCESS) r = vkBeginCommandBuffer(cmd, &begin);
  if (r != VK_SUCCESS) return Error{std::string(what) + ": vkBeginCommandBuffer: " + vk_result_name(r)};
  record(cmd);
  r = vkEndCommandBuffer(cmd);
  if (r == VK_SUCCESS) r = vkResetFences(device, 1, &fence);
  VkSubmitInfo submit{};
  submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &cmd;
  if (r == VK_SUCCESS) r = vkQueueSubmit(queue, 1, &submit, fence);
  if (r != VK_SUCCESS) return Error{std::string(what) + ": submitting: " + vk_result_name(r)};
  r = vkWaitForFences(device, 1, &fence, VK_TRUE, UINT64_MAX);
  if (r != VK_SUCCESS) return Error{std::string(what) + ": vkWaitForFences: " + vk_result_name(r)};
  return Ok{};
}

Expected<std::unique_ptr<VulkanDevice>> open_vulkan_device(PFN_vkGetInstanceProcAddr get_instance_proc_addr,
                                                           const XrGraphicsBindingVulkan2KHR& binding) {
  auto vk = std::make_unique<VulkanDevice>();
  vk->instance = binding.instance;
  vk->physical_device = binding.physicalDevice;
  vk->device = binding.device;
  vk->queue_family = binding.queueFamilyIndex;
#define GAUSS_XR_HEADLESS_LOAD_INSTANCE(name)                                                         \
  vk->name = reinterpret_cast<PFN_##name>(get_instance_proc_addr(binding.instance, #name));          \
  if (vk->name == nullptr) return Error{"the app's vkGetInstanceProcAddr has no " #name};
  GAUSS_XR_HEADLESS_INSTANCE_FUNCTIONS(GAUSS_XR_HEADLESS_LOAD_INSTANCE)
#undef GAUSS_XR_HEADLESS_LOAD_INSTANCE
#define GAUSS_XR_HEADLESS_LOAD_DEVICE(name)                                                \
  vk->name = reinterpret_cast<PFN_##name>(vk->vkGetDeviceProcAddr(binding.device, #name)); \
  if (vk->name == nullptr) return Error{"vkGetDeviceProcAddr has no " #name};
  GAUSS_XR_HEADLESS_DEVICE_FUNCTIONS(GAUSS_XR_HEADLESS_LOAD_DEVICE)
#undef GAUSS_XR_HEADLESS_LOAD_DEVICE

  vk->vkGetDeviceQueue(binding.device, binding.queueFamilyIndex, binding.queueIndex, &vk->queue);
  VkCommandPoolCreateInfo pool{};
  pool.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
  pool.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pool.queueFamilyIndex = binding.queueFamilyIndex;
  VkResult r = vk->vkCreateCommandPool(vk->device, &pool, nullptr, &vk->pool);
  if (r != VK_SUCCESS) return Error{"vkCreateCommandPool: " + vk_result_name(r)};
  auto failed = [&](const char* what, VkResult result) {
    vk->destroy();
    return Error{std::string(what) + ": " + vk_result_name(result)};
  };
  VkCommandBufferAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
  alloc.commandPool = vk->pool;
  alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  alloc.commandBufferCount = 1;
  r = vk->vkAllocateCommandBuffers(vk->device, &alloc, &vk->cmd);
  if (r != VK_SUCCESS) return failed("vkAllocateCommandBuffers", r);
  VkFenceCreateInfo fence{};
  fence.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
  r = vk->vkCreateFence(vk->device, &fence, nullptr, &vk->fence);
  if (r != VK_SUCCESS) return failed("vkCreateFence", r);
  return vk;
}

}  // namespace gauss::xr_headless
