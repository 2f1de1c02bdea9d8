// Dedicated allocations: simple, leak-checked by validation, and well inside
// maxMemoryAllocationCount for the few large buffers a renderer needs.
#include "vk/memory.h"

#include "gauss/engine/log_text.h"
#include "gauss/render/vk_check.h"
#include "gauss/render/vk_context.h"

namespace gauss::vk {

Expected<Allocation> allocate_memory(Context& context, const VkMemoryRequirements& requirements,
                                     VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred,
                                     const std::string& what) {
  const std::uint32_t type = context.find_memory_type(requirements.memoryTypeBits, required, preferred);
  if (type == kNoMemoryType) {
    return Error{what + ": no memory type with the required properties (flags 0x" + std::to_string(required) +
                 ") on device '" + context.device_name() + "'"};
  }
  const VkMemoryType& mt = context.memory_properties().memoryTypes[type];
  const VkDeviceSize heap_size = context.memory_properties().memoryHeaps[mt.heapIndex].size;
  if (requirements.size > heap_size) {
    return Error{what + ": needs " + format_bytes(requirements.size) + " but memory heap " +
                 std::to_string(mt.heapIndex) + " holds only " + format_bytes(heap_size)};
  }
  VkMemoryAllocateInfo ai{};
  ai.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
  ai.allocationSize = requirements.size;
  ai.memoryTypeIndex = type;
  Allocation out;
  out.flags = mt.propertyFlags;
  const VkResult r = vkAllocateMemory(context.device(), &ai, nullptr, &out.memory);
  if (r != VK_SUCCESS) {
    return Error{what + ": vkAllocateMemory of " + format_bytes(requirements.size) + " failed with " +
                 result_name(r) + " (memory heap " + std::to_string(mt.heapIndex) + " holds " +
                 format_bytes(heap_size) + " in total, shared with every other allocation)"};
  }
  return out;
}

}  // namespace gauss::vk
