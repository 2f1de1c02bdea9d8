// Validation output: errors are printed and counted (tests fail on a non-zero count),
// warnings are printed only.
#include "vk/debug_messenger.h"

#include <cstdio>

namespace gauss::vk::detail {
namespace {

std::atomic<std::uint64_t> g_process_errors{0};

VKAPI_ATTR VkBool32 VKAPI_CALL on_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                          VkDebugUtilsMessageTypeFlagsEXT /*types*/,
                                          const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  auto* state = static_cast<Context::State*>(user);
  const char* text = (data && data->pMessage) ? data->pMessage : "(no message)";
  if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) {
    state->error_count.fetch_add(1);
    g_process_errors.fetch_add(1);
    {
      std::lock_guard lock(state->mutex);
      state->last_error = text;
    }
    std::fprintf(stderr, "[vulkan validation ERROR] %s\n", text);
  } else {
    std::fprintf(stderr, "[vulkan validation warning] %s\n", text);
  }
  // VK_FALSE: never abort the call that triggered the message (the spec requires it).
  return VK_FALSE;
}

}  // namespace

std::uint64_t process_error_count() noexcept { return g_process_errors.load(); }

VkDebugUtilsMessengerCreateInfoEXT messenger_create_info(Context::State* state) noexcept {
  VkDebugUtilsMessengerCreateInfoEXT ci{};
  ci.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT;
  ci.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  ci.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                   VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  ci.pfnUserCallback = on_message;
  ci.pUserData = state;
  return ci;
}

}  // namespace gauss::vk::detail
