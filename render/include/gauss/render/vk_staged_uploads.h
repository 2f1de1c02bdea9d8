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
// starts a new copy group behind a barrier), so "write slot 5, clear slot 5" in one frame
// leaves slot 5 clear.
//
// Many regions: a GPU pays per VkBufferCopy region (an H100's upload pass took p95 3.9 ms
// for ~2 MB a frame in 8000 scattered slot edits, a region per run and buffer). A group of at least scatter_min_regions regions, all offsets
// and sizes multiples of 4 bytes, is applied by one compute dispatch (UploadScatter,
// shaders/upload_scatter.comp) reading a piece table staged in the ring. Anything the
// scatter cannot take (unaligned bytes, a buffer without STORAGE_BUFFER usage, bytes
// spanning more than one storage binding covers, no staging for the table) keeps
// vkCmdCopyBuffer: the same bytes land, in the same order, either way.
//
// Errors: a destination range outside its buffer (nothing queued), a staging block that
// cannot be allocated (the write is not queued; what was queued before stays).
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <volk.h>

#include "gauss/engine/result.h"
#include "gauss/render/vk_buffer.h"

namespace gauss::vk {

class Context;
class FrameRing;
class UploadScatter;

// A buffer as a queued copy group knows it: the group keeps handles, not Buffer objects
// (those may move before record()), and what the compute scatter must check.
struct UploadBufferRef {
  VkBuffer handle{VK_NULL_HANDLE};
  VkDeviceSize size{0};
  bool storage{false};  // created with STORAGE_BUFFER usage
};
UploadBufferRef upload_buffer_ref(const Buffer& buffer) noexcept;

// Counts since creation; a frame's are the difference across its record().
struct StagedUploadStats {
  std::uint64_t writes{0};
  std::uint64_t bytes{0};
  std::uint64_t copy_regions{0};        // VkBufferCopy regions recorded
  std::uint64_t copy_groups{0};         // vkCmdCopyBuffer calls recorded
  std::uint64_t scatter_groups{0};      // groups applied by the compute scatter
  std::uint64_t scatter_regions{0};     // their regions (not in copy_regions)
  std::uint64_t scatter_pieces{0};      // their piece-table entries (a region is 1 or more)
  std::uint64_t scatter_dispatches{0};  // vkCmdDispatch calls of the scatter
  std::uint64_t scatter_fallbacks{0};   // groups large enough to scatter that were copied
  std::uint64_t ring_grows{0};
  VkDeviceSize ring_bytes{0};           // current ring size
};

// Groups with at least this many regions scatter by default, chosen by device type from
// `gauss-bench upload` (GPU time of R scattered 64-byte regions, copies against one
// scatter dispatch; 2026-11-27):
// - a GPU pays per copy region: on an H100 copies took 6.1 / 13.7 / 23.7 / 83 us for
//   1 / 4 / 8 / 32 regions, the scatter 9.3 us for any of them, so 4 regions and up scatter;
// - lavapipe copies a region with a memcpy and runs a dispatch on its threads: copies won
//   up to 32 regions (0.056 ms against 0.064), the scatter from 64 (0.060 against 0.072).
inline constexpr std::uint32_t kGpuScatterMinRegions = 4;
inline constexpr std::uint32_t kCpuScatterMinRegions = 64;
// StagedUploadsCreateInfo::scatter_min_regions's default: one of the two above, by device.
inline constexpr std::uint32_t kDeviceScatterMinRegions = 0xFFFFFFFEu;
std::uint32_t device_scatter_min_regions(const Context& context) noexcept;

struct StagedUploadsCreateInfo {
  VkDeviceSize initial_bytes{4u << 20};  // first staging ring size (at least 64 KiB)
  // The ring never grows past this many bytes (0: no cap); a write that needs more fails
  // (nothing queued) and a piece table that finds no room falls back to copies.
  VkDeviceSize max_ring_bytes{0};
  // A word-aligned group of at least this many regions is applied by the compute scatter
  // (0 scatters every word-aligned group; UINT32_MAX never scatters; kDeviceScatterMinRegions
  // takes the device's, device_scatter_min_regions()).
  std::uint32_t scatter_min_regions{kDeviceScatterMinRegions};
  // Most bytes one scatter binding covers (0: maxStorageBufferRange). Lower only in tests.
  VkDeviceSize scatter_max_binding_bytes{0};
};

class StagedUploads {
 public:
  // `ring` supplies serials and deferred destruction; both must outlive this object.
  // Errors: the ring's allocation (or an initial size past max_ring_bytes), the scatter
  // pipeline's creation.
  static Expected<std::unique_ptr<StagedUploads>> create(Context& context, FrameRing& ring,
                                                          const StagedUploadsCreateInfo& info = {});
  ~StagedUploads();
  StagedUploads(const StagedUploads&) = delete;
  StagedUploads& operator=(const StagedUploads&) = delete;

  // Queues `size` bytes from `data` for dst[offset, offset + size).
  Status write(const Buffer& dst, VkDeviceSize offset, const void* data, VkDeviceSize size);
  // Reserves `size` bytes of staging for dst[offset, ...) and returns where to write
  // them; fill them before the next record(). Packing straight into staging saves a copy.
  Expected<std::span<std::byte>> reserve(const Buffer& dst, VkDeviceSize offset, VkDeviceSize size);
  // Queues copies from a caller's host-visible buffer `src` (bytes packed elsewhere, e.g.
  // on another thread) into `dst`, in order with the other writes to `dst` (a copy group
  // of its own, behind a barrier when `dst` already has writes queued). The regions must
  // not overlap each other in `dst`. The caller keeps `src` and its bytes unchanged until
  // the frame that records them has finished (FrameRing serial). Only a `src` with
  // STORAGE_BUFFER usage can be read by the scatter; other sources are always copied.
  // Errors: a region outside `src` or `dst` (nothing queued).
  Status copy_from(const Buffer& src, const Buffer& dst, std::span<const VkBufferCopy> regions);

  bool empty() const noexcept { return groups_.empty(); }
  // Records every queued copy into `cmd` (the current frame of the ring), each group as
  // vkCmdCopyBuffer or a scatter dispatch, then a barrier making transfer and compute
  // writes visible to compute, vertex/index, fragment, indirect and transfer access. A
  // scatter leaves its compute pipeline and descriptors bound. Piece tables are staged
  // here (the ring may grow). Nothing is forgotten until submitted(): a frame abandoned
  // after record() leaves every write queued for the next frame. No writes between
  // record() and submitted().
  void record(VkCommandBuffer cmd);
  // The frame that record() went into was submitted: its copies are done with, and the
  // staging bytes are released once that frame has finished.
  void submitted();

  const StagedUploadStats& stats() const noexcept { return stats_; }

 private:
  StagedUploads(Context& context, FrameRing& ring);  // in the .cpp, where UploadScatter is complete
  Expected<VkDeviceSize> allocate(VkDeviceSize size);
  Status grow(VkDeviceSize at_least);
  void reclaim();
  struct Group;
  struct StagedScatter;  // a group's piece table, staged in the ring by record()
  // Plans `g`'s scatter and stages its piece table in the ring; nothing when the group is
  // under the threshold or must be copied (a fallback is counted).
  std::optional<StagedScatter> stage_scatter(const Group& g);

  Context* context_;
  FrameRing* ring_;
  StagedUploadsCreateInfo info_;
  std::unique_ptr<UploadScatter> scatter_;
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

  struct Group {  // copies from one source into one destination, no two overlapping
    UploadBufferRef src;
    UploadBufferRef dst;
    std::vector<VkBufferCopy> regions;
    std::map<VkDeviceSize, VkDeviceSize> spans;  // dst offset -> end, for overlap checks
    bool barrier_before{false};
  };
  std::vector<Group> groups_;
  std::map<VkBuffer, std::size_t> open_group_;  // dst -> index of its newest group
  StagedUploadStats stats_;
};

}  // namespace gauss::vk
