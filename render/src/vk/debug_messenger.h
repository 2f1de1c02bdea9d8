#pragma once
// Private: the state the validation callback shares with its Context, and the
// messenger create info. Errors are counted per context and process-wide.
#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>

#include <volk.h>

#include "gauss/render/vk_context.h"

namespace gauss::vk {

struct Context::State {
  std::atomic<std::uint64_t> error_count{0};
  std::mutex mutex;  // guards last_error
  std::string last_error;
  std::mutex queue_mutex;    // vkQueueSubmit2 (the queue is externally synchronized)
  bool debug_utils{false};
};

namespace detail {

std::uint64_t process_error_count() noexcept;

// Severity WARNING | ERROR, all message types, user data = state.
VkDebugUtilsMessengerCreateInfoEXT messenger_create_info(Context::State* state) noexcept;

}  // namespace detail
}  // namespace gauss::vk
