// VkResult names and the failure paths of GAUSS_VK_CHECK / GAUSS_VK_TRY.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "gauss/render/vk_check.h"

namespace gauss::vk {

const char* result_name(VkResult result) noexcept {
  switch (result) {
#define GAUSS_VK_RESULT_CASE(name) \
  case name:                       \
    return #name;
    GAUSS_VK_RESULT_CASE(VK_SUCCESS)
    GAUSS_VK_RESULT_CASE(VK_NOT_READY)
    GAUSS_VK_RESULT_CASE(VK_TIMEOUT)
    GAUSS_VK_RESULT_CASE(VK_EVENT_SET)
    GAUSS_VK_RESULT_CASE(VK_EVENT_RESET)
    GAUSS_VK_RESULT_CASE(VK_INCOMPLETE)
    GAUSS_VK_RESULT_CASE(VK_ERROR_OUT_OF_HOST_MEMORY)
    GAUSS_VK_RESULT_CASE(VK_ERROR_OUT_OF_DEVICE_MEMORY)
    GAUSS_VK_RESULT_CASE(VK_ERROR_INITIALIZATION_FAILED)
    GAUSS_VK_RESULT_CASE(VK_ERROR_DEVICE_LOST)
    GAUSS_VK_RESULT_CASE(VK_ERROR_MEMORY_MAP_FAILED)
    GAUSS_VK_RESULT_CASE(VK_ERROR_LAYER_NOT_PRESENT)
    GAUSS_VK_RESULT_CASE(VK_ERROR_EXTENSION_NOT_PRESENT)
    GAUSS_VK_RESULT_CASE(VK_ERROR_FEATURE_NOT_PRESENT)
    GAUSS_VK_RESULT_CASE(VK_ERROR_INCOMPATIBLE_DRIVER)
    GAUSS_VK_RESULT_CASE(VK_ERROR_TOO_MANY_OBJECTS)
    GAUSS_VK_RESULT_CASE(VK_ERROR_FORMAT_NOT_SUPPORTED)
    GAUSS_VK_RESULT_CASE(VK_ERROR_FRAGMENTED_POOL)
    GAUSS_VK_RESULT_CASE(VK_ERROR_UNKNOWN)
    GAUSS_VK_RESULT_CASE(VK_ERROR_OUT_OF_POOL_MEMORY)
    GAUSS_VK_RESULT_CASE(VK_ERROR_INVALID_EXTERNAL_HANDLE)
    GAUSS_VK_RESULT_CASE(VK_ERROR_FRAGMENTATION)
    GAUSS_VK_RESULT_CASE(VK_ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS)
    GAUSS_VK_RESULT_CASE(VK_PIPELINE_COMPILE_REQUIRED)
    GAUSS_VK_RESULT_CASE(VK_ERROR_SURFACE_LOST_KHR)
    GAUSS_VK_RESULT_CASE(VK_ERROR_NATIVE_WINDOW_IN_USE_KHR)
    GAUSS_VK_RESULT_CASE(VK_SUBOPTIMAL_KHR)
    GAUSS_VK_RESULT_CASE(VK_ERROR_OUT_OF_DATE_KHR)
    GAUSS_VK_RESULT_CASE(VK_ERROR_INCOMPATIBLE_DISPLAY_KHR)
    GAUSS_VK_RESULT_CASE(VK_ERROR_VALIDATION_FAILED_EXT)
    GAUSS_VK_RESULT_CASE(VK_ERROR_INVALID_SHADER_NV)
    GAUSS_VK_RESULT_CASE(VK_ERROR_NOT_PERMITTED_KHR)
    GAUSS_VK_RESULT_CASE(VK_THREAD_IDLE_KHR)
    GAUSS_VK_RESULT_CASE(VK_THREAD_DONE_KHR)
    GAUSS_VK_RESULT_CASE(VK_OPERATION_DEFERRED_KHR)
    GAUSS_VK_RESULT_CASE(VK_OPERATION_NOT_DEFERRED_KHR)
#undef GAUSS_VK_RESULT_CASE
    default:
      break;
  }
  // Unknown to these headers (a newer driver): the number still identifies it.
  thread_local char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "VkResult(%d)", static_cast<int>(result));
  return buffer;
}

void fatal_result(VkResult result, const char* call, const char* file, int line) noexcept {
  std::fprintf(stderr, "%s:%d: fatal Vulkan error: %s failed with %s\n", file, line, call, result_name(result));
  std::fflush(stderr);
  std::abort();
}

Error result_error(VkResult result, const char* call, const char* file, int line) {
  return Error{std::string(call) + " failed with " + result_name(result) + " (" + file + ":" + std::to_string(line) +
               ")"};
}

}  // namespace gauss::vk
