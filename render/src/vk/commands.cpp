// CommandBuffer (record once, submit, wait) and synchronization2 barrier helpers.
#include "gauss/render/vk_commands.h"

#include <string>
#include <utility>

#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_check.h"
#include "gauss/render/vk_context.h"

namespace gauss::vk {

Expected<VkCommandBuffer> allocate_command_buffer(Context& context, VkCommandBufferLevel level) {
  VkCommandBufferAllocateInfo ai{};
  ai.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
  ai.commandPool = context.command_pool();
  ai.level = level;
  ai.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  GAUSS_VK_TRY(vkAllocateCommandBuffers(context.device(), &ai, &cmd));
  return cmd;
}

Expected<CommandBuffer> CommandBuffer::create(Context& context) {
  CommandBuffer cb;
  cb.context_ = &context;
  auto cmd = allocate_command_buffer(context, VK_COMMAND_BUFFER_LEVEL_PRIMARY);
  if (!cmd) return cmd.error();
  cb.cmd_ = *cmd;
  VkFenceCreateInfo fci{};
  fci.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
  GAUSS_VK_TRY(vkCreateFence(context.device(), &fci, nullptr, &cb.fence_));
  return cb;
}

CommandBuffer::~CommandBuffer() { destroy(); }

CommandBuffer::CommandBuffer(CommandBuffer&& other) noexcept
    : context_(std::exchange(other.context_, nullptr)),
      cmd_(std::exchange(other.cmd_, VK_NULL_HANDLE)),
      fence_(std::exchange(other.fence_, VK_NULL_HANDLE)),
      pending_(std::exchange(other.pending_, false)) {}

CommandBuffer& CommandBuffer::operator=(CommandBuffer&& other) noexcept {
  if (this != &other) {
    destroy();
    context_ = std::exchange(other.context_, nullptr);
    cmd_ = std::exchange(other.cmd_, VK_NULL_HANDLE);
    fence_ = std::exchange(other.fence_, VK_NULL_HANDLE);
    pending_ = std::exchange(other.pending_, false);
  }
  return *this;
}

void CommandBuffer::destroy() noexcept {
  if (context_ == nullptr) return;
  if (pending_) (void)vkWaitForFences(context_->device(), 1, &fence_, VK_TRUE, UINT64_MAX);
  if (fence_) vkDestroyFence(context_->device(), fence_, nullptr);
  if (cmd_) vkFreeCommandBuffers(context_->device(), context_->command_pool(), 1, &cmd_);
  context_ = nullptr;
  cmd_ = VK_NULL_HANDLE;
  fence_ = VK_NULL_HANDLE;
  pending_ = false;
}

Status CommandBuffer::begin() {
  if (context_ == nullptr) return Error{"CommandBuffer::begin on an empty command buffer"};
  if (auto st = wait(); !st) return st;
  GAUSS_VK_TRY(vkResetCommandBuffer(cmd_, 0));
  VkCommandBufferBeginInfo bi{};
  bi.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  GAUSS_VK_TRY(vkBeginCommandBuffer(cmd_, &bi));
  return Ok{};
}

Status CommandBuffer::end() {
  if (context_ == nullptr) return Error{"CommandBuffer::end on an empty command buffer"};
  GAUSS_VK_TRY(vkEndCommandBuffer(cmd_));
  return Ok{};
}

Status CommandBuffer::submit() {
  if (context_ == nullptr) return Error{"CommandBuffer::submit on an empty command buffer"};
  if (pending_) return Error{"CommandBuffer::submit: the previous submission was not waited for"};
  GAUSS_VK_TRY(vkResetFences(context_->device(), 1, &fence_));
  if (auto st = context_->submit(cmd_, fence_); !st) return st;
  pending_ = true;
  return Ok{};
}

Status CommandBuffer::wait() {
  if (!pending_) return Ok{};
  GAUSS_VK_TRY(vkWaitForFences(context_->device(), 1, &fence_, VK_TRUE, UINT64_MAX));
  pending_ = false;
  return Ok{};
}

Status CommandBuffer::submit_and_wait() {
  if (auto st = submit(); !st) return st;
  return wait();
}

VkImageMemoryBarrier2 image_barrier(VkImage image, VkImageAspectFlags aspect, VkImageLayout old_layout,
                                    VkImageLayout new_layout, VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                                    VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access) {
  VkImageMemoryBarrier2 b{};
  b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2;
  b.srcStageMask = src_stage;
  b.srcAccessMask = src_access;
  b.dstStageMask = dst_stage;
  b.dstAccessMask = dst_access;
  b.oldLayout = old_layout;
  b.newLayout = new_layout;
  b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {aspect, 0, 1, 0, 1};
  return b;
}

void record_image_barrier(VkCommandBuffer cmd, const VkImageMemoryBarrier2& barrier) {
  VkDependencyInfo di{};
  di.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  di.imageMemoryBarrierCount = 1;
  di.pImageMemoryBarriers = &barrier;
  vkCmdPipelineBarrier2(cmd, &di);
}

void memory_barrier(VkCommandBuffer cmd, VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                    VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access) {
  VkMemoryBarrier2 mb{};
  mb.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2;
  mb.srcStageMask = src_stage;
  mb.srcAccessMask = src_access;
  mb.dstStageMask = dst_stage;
  mb.dstAccessMask = dst_access;
  VkDependencyInfo di{};
  di.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  di.memoryBarrierCount = 1;
  di.pMemoryBarriers = &mb;
  vkCmdPipelineBarrier2(cmd, &di);
}

namespace {

// What a compute pass reads: shader reads/writes and its indirect dispatch arguments.
constexpr VkPipelineStageFlags2 kComputeStages =
    VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT;
constexpr VkAccessFlags2 kComputeAccess =
    VK_ACCESS_2_SHADER_READ_BIT | VK_ACCESS_2_SHADER_WRITE_BIT | VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT;

}  // namespace

void compute_to_compute_barrier(VkCommandBuffer cmd) {
  memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_WRITE_BIT, kComputeStages,
                 kComputeAccess);
}

void transfer_to_compute_barrier(VkCommandBuffer cmd) {
  memory_barrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, kComputeStages,
                 kComputeAccess);
}

void compute_to_transfer_barrier(VkCommandBuffer cmd) {
  memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_WRITE_BIT,
                 VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT | VK_PIPELINE_STAGE_2_HOST_BIT,
                 VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_HOST_READ_BIT);
}

void transfer_to_graphics_barrier(VkCommandBuffer cmd) {
  memory_barrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                 VK_PIPELINE_STAGE_2_VERTEX_INPUT_BIT | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                     VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                 VK_ACCESS_2_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_2_INDEX_READ_BIT | VK_ACCESS_2_SHADER_READ_BIT |
                     VK_ACCESS_2_UNIFORM_READ_BIT);
}

namespace {

Status check_region(const Buffer& buffer, VkDeviceSize offset, VkDeviceSize size, const char* role) {
  if (auto st = buffer.check_range(offset, size); !st) return Error{std::string(role) + ": " + st.message()};
  return Ok{};
}

}  // namespace

Status record_copy(VkCommandBuffer cmd, const Buffer& src, const Buffer& dst, std::span<const VkBufferCopy> regions) {
  for (const VkBufferCopy& r : regions) {
    if (auto st = check_region(src, r.srcOffset, r.size, "copy source"); !st) return st;
    if (auto st = check_region(dst, r.dstOffset, r.size, "copy destination"); !st) return st;
    if (r.size == 0) return Error{"copy from '" + src.name() + "' to '" + dst.name() + "': a region of size 0"};
  }
  if (regions.empty()) return Ok{};
  vkCmdCopyBuffer(cmd, src.handle(), dst.handle(), static_cast<std::uint32_t>(regions.size()), regions.data());
  return Ok{};
}

Status record_fill(VkCommandBuffer cmd, const Buffer& dst, VkDeviceSize offset, VkDeviceSize size,
                   std::uint32_t value) {
  const VkDeviceSize effective = size == VK_WHOLE_SIZE ? (offset <= dst.size() ? (dst.size() - offset) & ~VkDeviceSize{3} : 0) : size;
  if (auto st = check_region(dst, offset, effective, "fill"); !st) return st;
  if (offset % 4 != 0 || (size != VK_WHOLE_SIZE && size % 4 != 0)) {
    return Error{"fill of buffer '" + dst.name() + "': offset and size must be multiples of 4 (offset " +
                 std::to_string(offset) + ", size " + std::to_string(size) + ")"};
  }
  if (effective == 0) return Ok{};
  vkCmdFillBuffer(cmd, dst.handle(), offset, size, value);
  return Ok{};
}

}  // namespace gauss::vk
