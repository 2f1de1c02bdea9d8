// Buffer: dedicated allocation, persistent mapping when host visible, staging otherwise.
#include "gauss/render/vk_buffer.h"

#include <cstring>
#include <utility>
#include <vector>

#include "gauss/engine/log_text.h"
#include "gauss/render/vk_check.h"
#include "gauss/render/vk_commands.h"
#include "gauss/render/vk_context.h"
#include "vk/memory.h"

namespace gauss::vk {

Expected<Buffer> Buffer::create(Context& context, const BufferCreateInfo& info) {
  const std::string what = "buffer '" + info.name + "'";
  if (info.size == 0) return Error{what + ": size 0"};
  const VkDeviceSize max_range = context.max_storage_buffer_range();
  if ((info.usage & VK_BUFFER_USAGE_STORAGE_BUFFER_BIT) && info.size > max_range &&
      !info.allow_larger_than_binding_range) {
    return Error{what + ": " + format_bytes(info.size) + " exceeds maxStorageBufferRange " + format_bytes(max_range) +
                 " of device '" + context.device_name() +
                 "', the most one storage-buffer binding can cover; split the data over several buffers/bindings"};
  }

  Buffer b;
  b.context_ = &context;
  b.size_ = info.size;
  b.name_ = info.name;
  VkBufferCreateInfo ci{};
  ci.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  ci.size = info.size;
  ci.usage = info.usage | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  b.usage_ = ci.usage;
  ci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  GAUSS_VK_TRY(vkCreateBuffer(context.device(), &ci, nullptr, &b.buffer_));
  context.set_debug_name(VK_OBJECT_TYPE_BUFFER, reinterpret_cast<std::uint64_t>(b.buffer_), info.name.c_str());

  VkMemoryRequirements req{};
  vkGetBufferMemoryRequirements(context.device(), b.buffer_, &req);
  const VkMemoryPropertyFlags host = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  const VkMemoryPropertyFlags required = info.memory == MemoryUsage::DeviceLocal ? 0 : host;
  const VkMemoryPropertyFlags preferred =
      info.memory == MemoryUsage::HostVisible ? 0 : VkMemoryPropertyFlags{VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT};
  auto alloc = allocate_memory(context, req, required, preferred, what);
  if (!alloc) return alloc.error();
  b.memory_ = alloc->memory;
  GAUSS_VK_TRY(vkBindBufferMemory(context.device(), b.buffer_, b.memory_, 0));
  // Only coherent memory is mapped: no flush/invalidate bookkeeping anywhere.
  if ((alloc->flags & host) == host && !info.never_map) {
    GAUSS_VK_TRY(vkMapMemory(context.device(), b.memory_, 0, VK_WHOLE_SIZE, 0, &b.mapped_));
  }
  return b;
}

Buffer::~Buffer() { destroy(); }

Buffer::Buffer(Buffer&& other) noexcept
    : context_(std::exchange(other.context_, nullptr)),
      buffer_(std::exchange(other.buffer_, VK_NULL_HANDLE)),
      memory_(std::exchange(other.memory_, VK_NULL_HANDLE)),
      size_(std::exchange(other.size_, 0)),
      usage_(std::exchange(other.usage_, 0)),
      mapped_(std::exchange(other.mapped_, nullptr)),
      name_(std::move(other.name_)) {}

Buffer& Buffer::operator=(Buffer&& other) noexcept {
  if (this != &other) {
    destroy();
    context_ = std::exchange(other.context_, nullptr);
    buffer_ = std::exchange(other.buffer_, VK_NULL_HANDLE);
    memory_ = std::exchange(other.memory_, VK_NULL_HANDLE);
    size_ = std::exchange(other.size_, 0);
    usage_ = std::exchange(other.usage_, 0);
    mapped_ = std::exchange(other.mapped_, nullptr);
    name_ = std::move(other.name_);
  }
  return *this;
}

void Buffer::destroy() noexcept {
  if (context_ == nullptr) return;
  // Simple lifetime rule: the GPU may still read this buffer, so wait for the queue.
  (void)vkDeviceWaitIdle(context_->device());
  release();
}

void Buffer::destroy_after_gpu_finished() noexcept {
  if (context_ == nullptr) return;
  release();
}

void Buffer::release() noexcept {
  if (buffer_) vkDestroyBuffer(context_->device(), buffer_, nullptr);
  if (memory_) vkFreeMemory(context_->device(), memory_, nullptr);  // also unmaps
  buffer_ = VK_NULL_HANDLE;
  memory_ = VK_NULL_HANDLE;
  mapped_ = nullptr;
  context_ = nullptr;
}

Status Buffer::check_range(VkDeviceSize offset, VkDeviceSize size) const {
  if (!valid()) return Error{"buffer is empty (not created)"};
  if (offset > size_ || size > size_ - offset) {
    return Error{"buffer '" + name_ + "': range [" + std::to_string(offset) + ", " + std::to_string(offset) + " + " +
                 std::to_string(size) + ") lies outside its " + std::to_string(size_) + " bytes"};
  }
  return Ok{};
}

Status Buffer::upload(const void* data, VkDeviceSize size, VkDeviceSize offset) {
  const UploadRange range{data, size, offset};
  return upload_ranges(std::span<const UploadRange>(&range, 1));
}

Status Buffer::upload_ranges(std::span<const UploadRange> ranges) {
  VkDeviceSize total = 0;
  for (const UploadRange& r : ranges) {
    if (auto st = check_range(r.dst_offset, r.size); !st) return st;
    if (r.size > 0 && r.data == nullptr) return Error{"buffer '" + name_ + "': upload range with null data"};
    total += r.size;
  }
  if (total == 0) return Ok{};
  if (mapped_ != nullptr) {
    for (const UploadRange& r : ranges) {
      if (r.size > 0) std::memcpy(static_cast<std::byte*>(mapped_) + r.dst_offset, r.data, r.size);
    }
    return Ok{};
  }
  auto staging = Buffer::create(*context_, {.size = total,
                                            .usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                            .memory = MemoryUsage::HostVisible,
                                            .name = name_ + " upload staging"});
  if (!staging) return staging.error();
  std::vector<VkBufferCopy> regions;
  regions.reserve(ranges.size());
  VkDeviceSize cursor = 0;
  for (const UploadRange& r : ranges) {
    if (r.size == 0) continue;
    std::memcpy(static_cast<std::byte*>(staging->mapped()) + cursor, r.data, r.size);
    regions.push_back({cursor, r.dst_offset, r.size});
    cursor += r.size;
  }
  return context_->submit_and_wait([&](VkCommandBuffer cmd) {
    vkCmdCopyBuffer(cmd, staging->handle(), buffer_, static_cast<std::uint32_t>(regions.size()), regions.data());
  });
}

Status Buffer::download(void* out, VkDeviceSize size, VkDeviceSize offset) const {
  if (auto st = check_range(offset, size); !st) return st;
  if (size == 0) return Ok{};
  if (out == nullptr) return Error{"buffer '" + name_ + "': download into a null pointer"};
  if (mapped_ != nullptr) {
    std::memcpy(out, static_cast<const std::byte*>(mapped_) + offset, size);
    return Ok{};
  }
  auto staging = Buffer::create(*context_, {.size = size,
                                            .usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                            .memory = MemoryUsage::HostVisible,
                                            .name = name_ + " download staging"});
  if (!staging) return staging.error();
  const VkBufferCopy region{offset, 0, size};
  auto st = context_->submit_and_wait([&](VkCommandBuffer cmd) {
    vkCmdCopyBuffer(cmd, buffer_, staging->handle(), 1, &region);
    // The copy's writes must be visible to the host read below.
    memory_barrier(cmd, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                   VK_ACCESS_2_HOST_READ_BIT);
  });
  if (!st) return st;
  std::memcpy(out, staging->mapped(), size);
  return Ok{};
}

}  // namespace gauss::vk
