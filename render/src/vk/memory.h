#pragma once
// Private: one dedicated vkAllocateMemory per buffer/image, with an error that says
// what was being allocated, how big it is and how big the heap is (lavapipe: 2 GiB).
#include <string>

#include <volk.h>

#include "gauss/engine/result.h"

namespace gauss::vk {

class Context;

struct Allocation {
  VkDeviceMemory memory{VK_NULL_HANDLE};
  VkMemoryPropertyFlags flags{0};
};

// `required` must be present; `preferred` is taken when some allowed type has it.
Expected<Allocation> allocate_memory(Context& context, const VkMemoryRequirements& requirements,
                                     VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred,
                                     const std::string& what);

}  // namespace gauss::vk
