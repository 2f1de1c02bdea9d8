// XR_KHR_vulkan_enable2: the app makes its VkInstance and VkDevice through the runtime,
// which passes its create infos on unchanged (the runtime needs no Vulkan extensions: it
// only makes images and copies them), and learns which physical device to use.
#include "entry_points.h"
#include "runtime.h"
#include "xr_util.h"

namespace gauss::xr_headless {
namespace {

XrResult check(const char* fn, XrInstance instance, XrSystemId system_id, Instance** out) {
  *out = find(instance);
  if (*out == nullptr) return XR_ERROR_HANDLE_INVALID;
  if (!(*out)->vulkan_enable2) return fail(XR_ERROR_FUNCTION_UNSUPPORTED, fn, "XR_KHR_vulkan_enable2 is not enabled");
  if (system_id != kSystemId) return XR_ERROR_SYSTEM_INVALID;
  return XR_SUCCESS;
}

}  // namespace

XrResult xrGetVulkanGraphicsRequirements2KHR(XrInstance instance, XrSystemId system_id,
                                             XrGraphicsRequirementsVulkanKHR* requirements) {
  const char* fn = "xrGetVulkanGraphicsRequirements2KHR";
  const auto lock = lock_runtime();
  Instance* inst = nullptr;
  if (const XrResult r = check(fn, instance, system_id, &inst); XR_FAILED(r)) return r;
  if (!typed(requirements, XR_TYPE_GRAPHICS_REQUIREMENTS_VULKAN2_KHR))
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "graphicsRequirements must be an XrGraphicsRequirementsVulkan2KHR");
  requirements->minApiVersionSupported = XR_MAKE_VERSION(1, 0, 0);
  requirements->maxApiVersionSupported = XR_MAKE_VERSION(1, 3, 0);
  inst->graphics_requirements_queried = true;
  return XR_SUCCESS;
}

XrResult xrCreateVulkanInstanceKHR(XrInstance instance, const XrVulkanInstanceCreateInfoKHR* create_info,
                                   VkInstance* vulkan_instance, VkResult* vulkan_result) {
  const char* fn = "xrCreateVulkanInstanceKHR";
  const auto lock = lock_runtime();
  Instance* inst = nullptr;
  if (!typed(create_info, XR_TYPE_VULKAN_INSTANCE_CREATE_INFO_KHR))
    return find(instance) == nullptr ? XR_ERROR_HANDLE_INVALID
                                     : fail(XR_ERROR_VALIDATION_FAILURE, fn, "createInfo must be an XrVulkanInstanceCreateInfoKHR");
  if (const XrResult r = check(fn, instance, create_info->systemId, &inst); XR_FAILED(r)) return r;
  if (create_info->createFlags != 0 || create_info->pfnGetInstanceProcAddr == nullptr ||
      create_info->vulkanCreateInfo == nullptr || vulkan_instance == nullptr || vulkan_result == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn,
                "createFlags must be 0; pfnGetInstanceProcAddr, vulkanCreateInfo and the outputs non-null");
  auto create = reinterpret_cast<PFN_vkCreateInstance>(create_info->pfnGetInstanceProcAddr(nullptr, "vkCreateInstance"));
  if (create == nullptr) return fail(XR_ERROR_RUNTIME_FAILURE, fn, "the app's vkGetInstanceProcAddr has no vkCreateInstance");
  // A Vulkan failure is no OpenXR failure: the call succeeds and vulkanResult says what
  // Vulkan said (as hello_xr and Monado treat it).
  *vulkan_result = create(create_info->vulkanCreateInfo, create_info->vulkanAllocator, vulkan_instance);
  if (*vulkan_result == VK_SUCCESS) inst->vk_instances[*vulkan_instance] = create_info->pfnGetInstanceProcAddr;
  return XR_SUCCESS;
}

XrResult xrGetVulkanGraphicsDevice2KHR(XrInstance instance, const XrVulkanGraphicsDeviceGetInfoKHR* get_info,
                                       VkPhysicalDevice* physical_device) {
  const char* fn = "xrGetVulkanGraphicsDevice2KHR";
  const auto lock = lock_runtime();
  Instance* inst = nullptr;
  if (!typed(get_info, XR_TYPE_VULKAN_GRAPHICS_DEVICE_GET_INFO_KHR))
    return find(instance) == nullptr ? XR_ERROR_HANDLE_INVALID
                                     : fail(XR_ERROR_VALIDATION_FAILURE, fn, "getInfo must be an XrVulkanGraphicsDeviceGetInfoKHR");
  if (const XrResult r = check(fn, instance, get_info->systemId, &inst); XR_FAILED(r)) return r;
  if (get_info->vulkanInstance == VK_NULL_HANDLE || physical_device == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn, "vulkanInstance and vulkanPhysicalDevice must be non-null");
  // An instance the app made itself is served through the process's Vulkan loader.
  auto it = inst->vk_instances.find(get_info->vulkanInstance);
  PFN_vkGetInstanceProcAddr gipa = it != inst->vk_instances.end() ? it->second : loaded_vulkan_get_instance_proc_addr();
  auto enumerate = gipa ? reinterpret_cast<PFN_vkEnumeratePhysicalDevices>(
                              gipa(get_info->vulkanInstance, "vkEnumeratePhysicalDevices"))
                        : nullptr;
  if (enumerate == nullptr) return fail(XR_ERROR_RUNTIME_FAILURE, fn, "cannot reach vkEnumeratePhysicalDevices");
  // The headset is "plugged into" the first device: with lavapipe the only one.
  std::uint32_t count = 1;
  VkPhysicalDevice first = VK_NULL_HANDLE;
  const VkResult r = enumerate(get_info->vulkanInstance, &count, &first);
  if ((r != VK_SUCCESS && r != VK_INCOMPLETE) || count == 0 || first == VK_NULL_HANDLE)
    return fail(XR_ERROR_RUNTIME_FAILURE, fn, "the Vulkan instance has no physical device (" + vk_result_name(r) + ")");
  if (it == inst->vk_instances.end()) inst->vk_instances[get_info->vulkanInstance] = gipa;
  inst->vk_physical_devices[first] = get_info->vulkanInstance;
  *physical_device = first;
  return XR_SUCCESS;
}

XrResult xrCreateVulkanDeviceKHR(XrInstance instance, const XrVulkanDeviceCreateInfoKHR* create_info,
                                 VkDevice* vulkan_device, VkResult* vulkan_result) {
  const char* fn = "xrCreateVulkanDeviceKHR";
  const auto lock = lock_runtime();
  Instance* inst = nullptr;
  if (!typed(create_info, XR_TYPE_VULKAN_DEVICE_CREATE_INFO_KHR))
    return find(instance) == nullptr ? XR_ERROR_HANDLE_INVALID
                                     : fail(XR_ERROR_VALIDATION_FAILURE, fn, "createInfo must be an XrVulkanDeviceCreateInfoKHR");
  if (const XrResult r = check(fn, instance, create_info->systemId, &inst); XR_FAILED(r)) return r;
  if (create_info->createFlags != 0 || create_info->pfnGetInstanceProcAddr == nullptr ||
      create_info->vulkanCreateInfo == nullptr || vulkan_device == nullptr || vulkan_result == nullptr)
    return fail(XR_ERROR_VALIDATION_FAILURE, fn,
                "createFlags must be 0; pfnGetInstanceProcAddr, vulkanCreateInfo and the outputs non-null");
  auto pd = inst->vk_physical_devices.find(create_info->vulkanPhysicalDevice);
  if (pd == inst->vk_physical_devices.end())
    return fail(XR_ERROR_HANDLE_INVALID, fn, "vulkanPhysicalDevice is not the one xrGetVulkanGraphicsDevice2KHR returned");
  auto create = reinterpret_cast<PFN_vkCreateDevice>(create_info->pfnGetInstanceProcAddr(pd->second, "vkCreateDevice"));
  if (create == nullptr) return fail(XR_ERROR_RUNTIME_FAILURE, fn, "the app's vkGetInstanceProcAddr has no vkCreateDevice");
  *vulkan_result = create(create_info->vulkanPhysicalDevice, create_info->vulkanCreateInfo, create_info->vulkanAllocator,
                          vulkan_device);
  if (*vulkan_result == VK_SUCCESS) {
    // Remembered so xrCreateSession can check the binding's queue exists.
    auto& queues = inst->vk_device_queues[*vulkan_device];
    const VkDeviceCreateInfo& ci = *create_info->vulkanCreateInfo;
    for (std::uint32_t i = 0; i < ci.queueCreateInfoCount; ++i)
      queues[ci.pQueueCreateInfos[i].queueFamilyIndex] += ci.pQueueCreateInfos[i].queueCount;
  }
  return XR_SUCCESS;
}

}  // namespace gauss::xr_headless
