#pragma once
// Vulkan result checking, active in every build type (never compiled out).
//
//   GAUSS_VK_CHECK(vkCall(...));   fatal: prints the call, file, line and the VkResult
//                                  name to stderr and aborts. For calls that can only
//                                  fail on a programming error or device loss.
//   GAUSS_VK_TRY(vkCall(...));     inside a function returning gauss::Status or
//                                  gauss::Expected<T>: returns an Error naming the call,
//                                  file, line and VkResult instead. For calls whose
//                                  failure the caller can handle (allocation, creation).
//
// VK_CHECK / VK_TRY are short aliases unless something else already defined them.
#include <string>

#include <volk.h>

#include "gauss/engine/result.h"

namespace gauss::vk {

// "VK_ERROR_OUT_OF_DEVICE_MEMORY" etc.; "VkResult(<n>)" for values this build does not know.
const char* result_name(VkResult result) noexcept;

// Prints "<file>:<line>: <call> failed: <VkResult name>" to stderr and aborts.
[[noreturn]] void fatal_result(VkResult result, const char* call, const char* file, int line) noexcept;

// The Error GAUSS_VK_TRY returns: "<call> failed with <VkResult name> (<file>:<line>)".
Error result_error(VkResult result, const char* call, const char* file, int line);

}  // namespace gauss::vk

#define GAUSS_VK_CHECK(call)                                                 \
  do {                                                                       \
    const VkResult gauss_vk_check_result_ = (call);                          \
    if (gauss_vk_check_result_ != VK_SUCCESS) {                              \
      ::gauss::vk::fatal_result(gauss_vk_check_result_, #call, __FILE__, __LINE__); \
    }                                                                        \
  } while (false)

#define GAUSS_VK_TRY(call)                                                   \
  do {                                                                       \
    const VkResult gauss_vk_try_result_ = (call);                            \
    if (gauss_vk_try_result_ != VK_SUCCESS) {                                \
      return ::gauss::vk::result_error(gauss_vk_try_result_, #call, __FILE__, __LINE__); \
    }                                                                        \
  } while (false)

#ifndef VK_CHECK
#define VK_CHECK(call) GAUSS_VK_CHECK(call)
#endif
#ifndef VK_TRY
#define VK_TRY(call) GAUSS_VK_TRY(call)
#endif
