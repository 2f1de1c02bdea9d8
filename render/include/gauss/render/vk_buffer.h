#pragma once
// gauss::vk::Buffer: one VkBuffer with its own memory allocation (RAII, move-only).
//
// Memory: MemoryUsage::DeviceLocal prefers DEVICE_LOCAL memory (on lavapipe every type
// is device local AND host visible); MemoryUsage::HostVisible requires HOST_VISIBLE |
// HOST_COHERENT (staging, readback); MemoryUsage::HostVisibleNearGpu requires the same and
// prefers DEVICE_LOCAL too (a discrete GPU's BAR window), for small per-frame data the GPU
// reads many times, where system memory would cost a bus round trip per read (the
// renderer's view constants and its counters: every workgroup of every pass reads a count,
// every indirect dispatch its arguments). Whenever the chosen memory is
// host visible the buffer stays persistently mapped and upload()/download() are plain
// memcpys; otherwise they go through a temporary staging buffer and a blocking copy on
// the queue. Code never assumes which case it got.
//
// Limits checked at creation, with errors naming the buffer:
//  - size 0 is an error;
//  - a buffer with STORAGE_BUFFER usage larger than maxStorageBufferRange (128 MiB on
//    lavapipe) is an error unless BufferCreateInfo::allow_larger_than_binding_range is set
//    (then every binding must cover at most that range; ComputePipeline::bind checks);
//  - allocation failure (lavapipe's heap is 2 GiB) reports the size and the heap size.
//
// Lifetime: destroying (or move-assigning over) a Buffer waits for the device to go
// idle first, so the GPU can never read freed memory. Simple and leak-free, but it
// stalls: keep buffers alive across frames instead of recreating them per frame.
// The same holds for Image, pipelines, TimestampQueries and CommandBuffer.
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include <volk.h>

#include "gauss/engine/result.h"

namespace gauss::vk {

class Context;

enum class MemoryUsage {
  DeviceLocal,  // GPU-side data (stable-slot SSBO, sort keys); staging used if not mappable
  HostVisible,  // CPU writes / reads every frame (staging, readback)
  HostVisibleNearGpu,  // as HostVisible, device-local where the device offers both
};

struct BufferCreateInfo {
  VkDeviceSize size{0};
  // Usage flags; TRANSFER_SRC | TRANSFER_DST are always added so upload/download work.
  VkBufferUsageFlags usage{VK_BUFFER_USAGE_STORAGE_BUFFER_BIT};
  MemoryUsage memory{MemoryUsage::DeviceLocal};
  // Debug name: in error messages and validation output.
  std::string name{"buffer"};
  // Allows a storage buffer larger than one binding may cover (see header comment).
  bool allow_larger_than_binding_range{false};
  // Keeps the buffer unmapped even when its memory is host visible, so upload() and
  // download() take the staging path a discrete GPU takes. Lets tests cover that path
  // on lavapipe, where all memory is host visible.
  bool never_map{false};
};

// One contiguous piece of a ranged upload: `size` bytes from `data` to `dst_offset`.
struct UploadRange {
  const void* data{nullptr};
  VkDeviceSize size{0};
  VkDeviceSize dst_offset{0};
};

class Buffer {
 public:
  static Expected<Buffer> create(Context& context, const BufferCreateInfo& info);

  Buffer() = default;  // empty: valid() == false
  ~Buffer();
  Buffer(Buffer&& other) noexcept;
  Buffer& operator=(Buffer&& other) noexcept;
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;

  bool valid() const noexcept { return buffer_ != VK_NULL_HANDLE; }
  VkBuffer handle() const noexcept { return buffer_; }
  VkDeviceSize size() const noexcept { return size_; }
  const std::string& name() const noexcept { return name_; }
  // CPU pointer to the whole buffer (persistently mapped): non-null when host visible.
  void* mapped() const noexcept { return mapped_; }
  bool host_visible() const noexcept { return mapped_ != nullptr; }
  // Usage the buffer was created with (TRANSFER_SRC | TRANSFER_DST included): lets a user
  // that may bind someone else's buffer (StagedUploads' scatter) check it may.
  VkBufferUsageFlags usage() const noexcept { return usage_; }

  // Writes bytes at `offset`. Blocking when staging is needed (waits for the copy).
  // Errors: range past the end (names buffer, offset, size), Vulkan failures.
  // Must not race with GPU work using the same bytes: callers order it (the blocking
  // helpers here wait for their own copies only).
  Status upload(const void* data, VkDeviceSize size, VkDeviceSize offset = 0);
  Status upload(std::span<const std::byte> bytes, VkDeviceSize offset = 0) {
    return upload(bytes.data(), bytes.size(), offset);
  }
  // Several ranges in one go (one staging buffer, one submission with one
  // VkBufferCopy per range). Every range is checked before anything is written, so
  // a bad range leaves the buffer untouched.
  Status upload_ranges(std::span<const UploadRange> ranges);

  // Reads `size` bytes at `offset` into `out`. Blocking; waits for the copy only —
  // the caller must have waited for GPU work writing the buffer (e.g. submit_and_wait).
  Status download(void* out, VkDeviceSize size, VkDeviceSize offset = 0) const;
  Status download(std::span<std::byte> bytes, VkDeviceSize offset = 0) const {
    return download(bytes.data(), bytes.size(), offset);
  }

  // Checks [offset, offset+size) lies inside the buffer; "buffer 'name': ..." otherwise.
  Status check_range(VkDeviceSize offset, VkDeviceSize size) const;

  // Destroys the buffer now WITHOUT waiting for the device: the caller knows that no
  // submitted work uses it any more (a FrameRing deferral ran after the fences of every
  // frame that could have used it). The frame path retires buffers this way, since the
  // destructor's device-wide wait would stall the frames in flight.
  void destroy_after_gpu_finished() noexcept;

 private:
  void destroy() noexcept;
  void release() noexcept;

  Context* context_{nullptr};
  VkBuffer buffer_{VK_NULL_HANDLE};
  VkDeviceMemory memory_{VK_NULL_HANDLE};
  VkDeviceSize size_{0};
  VkBufferUsageFlags usage_{0};
  void* mapped_{nullptr};
  std::string name_;
};

}  // namespace gauss::vk
