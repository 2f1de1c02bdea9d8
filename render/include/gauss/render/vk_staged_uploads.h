#pragma once
// gauss::vk::StagedUploads: host writes into device buffers that frames in flight may be
// reading. A write copies its bytes into a persistent, persistently mapped staging ring
// at once and queues a buffer copy; record() puts every queued copy into the command
// buffer of the next frame, ahead of the passes that read the destinations, so the GPU
// applies them in frame order and never while an earlier frame still reads the bytes.
//
// The ring: one host-visible buffer used front to back and wrapped; the bytes a frame's
// copies read are released when that frame's fence has signalled (FrameRing serials).
// When a frame needs more than is free, a larger block replaces the ring and the old
// block is handed to FrameRing::defer (destroyed after the frames that read it). No
// staging buffer is allocated per call.
//
// Order: writes to overlapping bytes of one destination keep their order (a later write
// starts a new copy group behind a transfer barrier), so "write slot 5, clear slot 5" in
// one frame leaves slot 5 clear.
//
// Errors: a destination range outside its buffer (nothing queued), a staging block that
// cannot be allocated (the write is not queued; what was queued before stays).
#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <vector>

#include <volk.h>

#include "gauss/engine/result.h"
#include "gauss/render/vk_buffer.h"

namespace gauss::vk {

class Context;
class FrameRing;

struct StagedUploadStats {
  std::uint64_t writes{0};
  std::uint64_t bytes{0};
  std::uint64_t copy_regions{0};   // VkBufferCopy regions recorded
  std::uint64_t copy_groups{0};    // vkCmdCopyBuffer calls recorded
  std::uint64_t ring_grows{0};
  VkDeviceSize ring_bytes{0};      // current ring size
};

class StagedUploads {
 public:
  // `ring` supplies serials and deferred destruction; both must outlive this object.
  static Expected<std::unique_ptr<StagedUploads>> create(Context& context, FrameRing& ring,
                                                          VkDeviceSize initial_bytes = 4u << 20);
  ~StagedUploads() = default;
  StagedUploads(const StagedUploads&) = delete;
  StagedUploads& operator=(const StagedUploads&) = delete;

  // Queues `size` bytes from `data` for dst[offset, offset + size).
  Status write(const Buffer& dst, VkDeviceSize offset, const void* data, VkDeviceSize size);
  // Reserves `size` bytes of staging for dst[offset, ...) and returns where to write
  // them; fill them before the next record(). Packing straight into staging saves a copy.
  Expected<std::span<std::byte>> reserve(const Buffer& dst, VkDeviceSize offset, VkDeviceSize size);
  // Queues copies from a caller's host-visible buffer `src` (bytes packed elsewhere, e.g.
  // on another thread) into `dst`, in order with the other writes to `dst` (a copy group
  // of its own, behind a transfer barrier when `dst` already has writes queued). The
  // regions must not overlap each other in `dst`. The caller keeps `src` and its bytes
  // unchanged until the frame that records them has finished (FrameRing serial).
  // Errors: a region outside `src` or `dst` (nothing queued).
  Status copy_from(const Buffer& src, const Buffer& dst, std::span<const VkBufferCopy> regions);

  bool empty() const noexcept { return groups_.empty(); }
  // Records every queued copy into `cmd` (the current frame of the ring), then a barrier
  // making them visible to compute, vertex/index and fragment reads. Nothing is
  // forgotten until submitted(): a frame abandoned after record() leaves every write
  // queued for the next frame. No writes between record() and submitted().
  void record(VkCommandBuffer cmd);
  // The frame that record() went into was submitted: its copies are done with, and the
  // staging bytes are released once that frame has finished.
  void submitted();

  const StagedUploadStats& stats() const noexcept { return stats_; }

 private:
  StagedUploads(Context& context, FrameRing& ring) : context_(&context), ring_(&ring) {}
  Expected<VkDeviceSize> allocate(VkDeviceSize size);
  Status grow(VkDeviceSize at_least);
  void reclaim();

  Context* context_;
  FrameRing* ring_;
  Buffer buffer_;
  VkDeviceSize head_{0};  // next free byte
  VkDeviceSize tail_{0};  // oldest byte still read by a frame in flight (or queued)
  VkDeviceSize used_{0};  // bytes between tail and head, wrap waste included
  struct Release {        // bytes up to `end` are free once frame `serial` finished
    std::uint64_t serial;
    VkDeviceSize end;
    VkDeviceSize bytes;
  };
  std::vector<Release> releases_;
  VkDeviceSize pending_bytes_{0};  // staged since the last record()

  struct Group {  // copies from the ring into one destination, no two overlapping
    VkBuffer src;
    VkBuffer dst;
    std::vector<VkBufferCopy> regions;
    std::map<VkDeviceSize, VkDeviceSize> spans;  // dst offset -> end, for overlap checks
    bool barrier_before{false};
  };
  std::vector<Group> groups_;
  std::map<VkBuffer, std::size_t> open_group_;  // dst -> index of its newest group
  StagedUploadStats stats_;
};

}  // namespace gauss::vk
