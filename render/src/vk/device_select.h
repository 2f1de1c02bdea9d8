#pragma once
// Private: physical device enumeration, suitability and choice (rules in vk_context.h).
#include <cstdint>
#include <string>
#include <vector>

#include <volk.h>

#include "gauss/engine/result.h"
#include "gauss/render/vk_context.h"

namespace gauss::vk::detail {

inline constexpr std::uint32_t kRequiredApi = VK_API_VERSION_1_3;

// "1.3.230"
std::string version_string(std::uint32_t version);

// What a windowed context asks of a device beyond the fixed requirements
// (ContextCreateInfo::device_extensions / create_surface). Default: nothing more.
struct ExtraRequirements {
  std::vector<std::string> device_extensions;
  // The chosen queue family must be able to present here (when not null).
  VkSurfaceKHR surface{VK_NULL_HANDLE};
  // Fetched from the instance that owns `surface` (volk's global pointer may come from
  // an instance without VK_KHR_surface); required when `surface` is set.
  PFN_vkGetPhysicalDeviceSurfaceSupportKHR get_surface_support{nullptr};
};

// Queue family with graphics + compute and timestamps (and present support for
// extra->surface when given), or ~0u.
std::uint32_t pick_queue_family(VkPhysicalDevice device, std::uint32_t* out_timestamp_bits,
                                const ExtraRequirements* extra = nullptr);

// The feature structs of Vulkan 1.0-1.3, chained for vkGetPhysicalDeviceFeatures2 /
// VkDeviceCreateInfo::pNext. Not copyable: the chain points into itself.
struct FeatureChain {
  VkPhysicalDeviceFeatures2 f2{};
  VkPhysicalDeviceVulkan11Features f11{};
  VkPhysicalDeviceVulkan12Features f12{};
  VkPhysicalDeviceVulkan13Features f13{};
  FeatureChain();
  FeatureChain(const FeatureChain&) = delete;
  FeatureChain& operator=(const FeatureChain&) = delete;
};

struct Candidate {
  VkPhysicalDevice handle{VK_NULL_HANDLE};
  DeviceInfo info;
};

// Every physical device with its suitability (including `extra`'s requirements).
Expected<std::vector<Candidate>> enumerate(VkInstance instance, const ExtraRequirements& extra = {});

// The device an override names (index or name part; `override_source` names where the
// value came from in errors), or the best suitable one when `override_value` is empty.
Expected<Candidate> choose_device(const std::vector<Candidate>& candidates, const std::string& override_value,
                                  const char* override_source);

// `required` (an XR runtime's device) among the candidates, when it is suitable; else an
// error with its reason.
Expected<Candidate> require_device(const std::vector<Candidate>& candidates, VkPhysicalDevice required);

}  // namespace gauss::vk::detail
