#pragma once
// Command recording helpers: an RAII primary command buffer for work that is
// recorded once and submitted repeatedly (a frame), and synchronization2 barrier
// helpers for the common hazards between passes. One-shot work uses
// Context::submit_and_wait(record).
#include <cstdint>
#include <span>

#include <volk.h>

#include "gauss/engine/result.h"

namespace gauss::vk {

class Context;
class Buffer;

class CommandBuffer {
 public:
  // Allocates from the context's pool plus a fence for submit_and_wait / wait.
  static Expected<CommandBuffer> create(Context& context);

  CommandBuffer() = default;
  ~CommandBuffer();  // waits for an outstanding submission before freeing
  CommandBuffer(CommandBuffer&& other) noexcept;
  CommandBuffer& operator=(CommandBuffer&& other) noexcept;
  CommandBuffer(const CommandBuffer&) = delete;
  CommandBuffer& operator=(const CommandBuffer&) = delete;

  VkCommandBuffer handle() const noexcept { return cmd_; }

  // Resets and begins recording (ONE_TIME_SUBMIT). Waits for a previous submission
  // of this buffer first, so re-recording is always safe.
  Status begin();
  Status end();
  // Submits; returns at once. wait() blocks until the GPU has finished it.
  Status submit();
  Status wait();
  Status submit_and_wait();

 private:
  void destroy() noexcept;

  Context* context_{nullptr};
  VkCommandBuffer cmd_{VK_NULL_HANDLE};
  VkFence fence_{VK_NULL_HANDLE};
  bool pending_{false};
};

// One command buffer of `level` from the context's pool (resettable one by one). The
// caller frees it with vkFreeCommandBuffers on the same pool.
Expected<VkCommandBuffer> allocate_command_buffer(Context& context, VkCommandBufferLevel level);

// A synchronization2 barrier of mip 0 / layer 0 of `image` (no queue transfer).
VkImageMemoryBarrier2 image_barrier(VkImage image, VkImageAspectFlags aspect, VkImageLayout old_layout,
                                    VkImageLayout new_layout, VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                                    VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access);

// Records one image barrier (e.g. of image_barrier()) for an image the caller tracks itself
// (an OpenXR swapchain image, which is not a vk::Image).
void record_image_barrier(VkCommandBuffer cmd, const VkImageMemoryBarrier2& barrier);

// Global memory barrier (synchronization2).
void memory_barrier(VkCommandBuffer cmd, VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                    VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access);

// Compute shader writes -> later compute shader reads/writes and indirect dispatch
// arguments (pass to pass).
void compute_to_compute_barrier(VkCommandBuffer cmd);
// Transfer writes (uploads, fills, clears) -> compute shader reads/writes and indirect
// dispatch arguments.
void transfer_to_compute_barrier(VkCommandBuffer cmd);
// Compute shader writes -> transfer reads (readback) and host reads.
void compute_to_transfer_barrier(VkCommandBuffer cmd);
// Transfer writes -> vertex input / index reads and vertex/fragment shader reads.
void transfer_to_graphics_barrier(VkCommandBuffer cmd);

// Records vkCmdCopyBuffer with `regions` after checking every region lies inside
// both buffers (nothing is recorded on error; the error names buffers and region).
Status record_copy(VkCommandBuffer cmd, const Buffer& src, const Buffer& dst,
                   std::span<const VkBufferCopy> regions);

// Records vkCmdFillBuffer of `size` bytes (multiple of 4, or VK_WHOLE_SIZE) at
// `offset` (multiple of 4) with `value`; checked like record_copy.
Status record_fill(VkCommandBuffer cmd, const Buffer& dst, VkDeviceSize offset, VkDeviceSize size,
                   std::uint32_t value);

}  // namespace gauss::vk
