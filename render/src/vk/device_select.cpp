// Physical device enumeration, suitability checks and the choice rules of vk_context.h.
#include "vk/device_select.h"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "gauss/render/vk_check.h"

namespace gauss::vk {
namespace detail {
namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

bool has_device_extension(VkPhysicalDevice pd, const char* name) {
  std::uint32_t count = 0;
  if (vkEnumerateDeviceExtensionProperties(pd, nullptr, &count, nullptr) != VK_SUCCESS) return false;
  std::vector<VkExtensionProperties> exts(count);
  if (vkEnumerateDeviceExtensionProperties(pd, nullptr, &count, exts.data()) != VK_SUCCESS) return false;
  return std::any_of(exts.begin(), exts.end(), [&](const VkExtensionProperties& e) { return std::strcmp(e.extensionName, name) == 0; });
}

// Why a device cannot be used ("" when it can).
std::string unsuitable_reason(VkPhysicalDevice pd, const VkPhysicalDeviceProperties& props,
                              const ExtraRequirements& extra) {
  if (props.apiVersion < kRequiredApi) {
    return "Vulkan " + version_string(props.apiVersion) + " < 1.3";
  }
  if (pick_queue_family(pd, nullptr) == ~0u) return "no queue family with graphics + compute + timestamps";
  if (extra.surface != VK_NULL_HANDLE && pick_queue_family(pd, nullptr, &extra) == ~0u) {
    return "no queue family with graphics + compute + timestamps that can present to the window surface";
  }
  if (!has_device_extension(pd, VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME)) return "no VK_KHR_push_descriptor";
  for (const auto& ext : extra.device_extensions) {
    if (!has_device_extension(pd, ext.c_str())) return "no " + ext;
  }
  FeatureChain fc;
  vkGetPhysicalDeviceFeatures2(pd, &fc.f2);
  if (!fc.f13.dynamicRendering) return "no dynamicRendering";
  if (!fc.f13.synchronization2) return "no synchronization2";
  return "";
}

int type_rank(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 1;
    default: return 0;
  }
}

std::string describe(const std::vector<Candidate>& candidates) {
  std::string s;
  for (const auto& c : candidates) {
    s += "\n  [" + std::to_string(c.info.index) + "] " + c.info.name + " (" + device_type_name(c.info.type) +
         ", Vulkan " + version_string(c.info.api_version) + ")";
    if (!c.info.unsuitable_reason.empty()) s += " unsuitable: " + c.info.unsuitable_reason;
  }
  return s;
}

}  // namespace

std::string version_string(std::uint32_t v) {
  return std::to_string(VK_API_VERSION_MAJOR(v)) + "." + std::to_string(VK_API_VERSION_MINOR(v)) + "." +
         std::to_string(VK_API_VERSION_PATCH(v));
}

std::uint32_t pick_queue_family(VkPhysicalDevice pd, std::uint32_t* out_timestamp_bits,
                                const ExtraRequirements* extra) {
  std::uint32_t count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &count, nullptr);
  std::vector<VkQueueFamilyProperties> families(count);
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &count, families.data());
  for (std::uint32_t i = 0; i < count; ++i) {
    const VkQueueFlags need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
    if ((families[i].queueFlags & need) == need && families[i].timestampValidBits > 0) {
      if (extra != nullptr && extra->surface != VK_NULL_HANDLE) {
        VkBool32 present = VK_FALSE;
        if (extra->get_surface_support == nullptr ||
            extra->get_surface_support(pd, i, extra->surface, &present) != VK_SUCCESS || present != VK_TRUE) {
          continue;
        }
      }
      if (out_timestamp_bits) *out_timestamp_bits = families[i].timestampValidBits;
      return i;
    }
  }
  return ~0u;
}

FeatureChain::FeatureChain() {
  f2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
  f11.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_1_FEATURES;
  f12.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES;
  f13.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES;
  f2.pNext = &f11;
  f11.pNext = &f12;
  f12.pNext = &f13;
}

Expected<std::vector<Candidate>> enumerate(VkInstance instance, const ExtraRequirements& extra) {
  std::uint32_t count = 0;
  GAUSS_VK_TRY(vkEnumeratePhysicalDevices(instance, &count, nullptr));
  std::vector<VkPhysicalDevice> devices(count);
  GAUSS_VK_TRY(vkEnumeratePhysicalDevices(instance, &count, devices.data()));
  std::vector<Candidate> out;
  for (std::uint32_t i = 0; i < count; ++i) {
    VkPhysicalDeviceProperties props{};
    vkGetPhysicalDeviceProperties(devices[i], &props);
    Candidate c;
    c.handle = devices[i];
    c.info.index = i;
    c.info.name = props.deviceName;
    c.info.type = props.deviceType;
    c.info.api_version = props.apiVersion;
    c.info.unsuitable_reason = unsuitable_reason(devices[i], props, extra);
    out.push_back(std::move(c));
  }
  return out;
}

Expected<Candidate> choose_device(const std::vector<Candidate>& candidates, const std::string& override_value,
                                  const char* override_source) {
  if (candidates.empty()) {
    return Error{"no Vulkan physical device found (is a Vulkan driver installed? lavapipe: mesa-vulkan-drivers)"};
  }
  if (!override_value.empty()) {
    const bool numeric = std::all_of(override_value.begin(), override_value.end(),
                                     [](unsigned char ch) { return std::isdigit(ch) != 0; });
    const std::string needle = lower(override_value);
    for (const auto& c : candidates) {
      const bool match = numeric ? std::to_string(c.info.index) == override_value
                                 : lower(c.info.name).find(needle) != std::string::npos;
      if (!match) continue;
      if (!c.info.unsuitable_reason.empty()) {
        return Error{std::string("device '") + c.info.name + "' chosen by " + override_source + "='" + override_value +
                     "' is unsuitable: " + c.info.unsuitable_reason + "; available devices:" + describe(candidates)};
      }
      return c;
    }
    return Error{std::string("no Vulkan device matches ") + override_source + "='" + override_value +
                 "' (an index or a case-insensitive part of the device name); available devices:" +
                 describe(candidates)};
  }
  const Candidate* best = nullptr;
  for (const auto& c : candidates) {
    if (!c.info.unsuitable_reason.empty()) continue;
    if (best == nullptr || type_rank(c.info.type) > type_rank(best->info.type)) best = &c;
  }
  if (best == nullptr) return Error{"no suitable Vulkan device; available devices:" + describe(candidates)};
  return *best;
}

Expected<Candidate> require_device(const std::vector<Candidate>& candidates, VkPhysicalDevice required) {
  for (const auto& c : candidates) {
    if (c.handle != required) continue;
    if (!c.info.unsuitable_reason.empty())
      return Error{std::string("the XR runtime's Vulkan device '") + c.info.name +
                   "' is unsuitable: " + c.info.unsuitable_reason};
    return c;
  }
  return Error{"the XR runtime's Vulkan device is not one this instance enumerates; available devices:" +
               describe(candidates)};
}

}  // namespace detail

const char* device_type_name(VkPhysicalDeviceType type) noexcept {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    default: return "other";
  }
}

std::string device_override_from_args(int argc, const char* const* argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i] ? argv[i] : "";
    if (arg == "--device" && i + 1 < argc && argv[i + 1]) return argv[i + 1];
    if (arg.rfind("--device=", 0) == 0) return std::string(arg.substr(9));
  }
  return "";
}

}  // namespace gauss::vk
