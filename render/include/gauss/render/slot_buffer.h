#pragma once
// gauss::render::SlotBuffer: the stable-slot Gaussian store on the GPU. Capacity is fixed
// at creation; a Gaussian keeps its slot while resident. Per slot: core attributes
// (64 B), SH rest of bands 1-2 (up to 24 floats; absent for degree 0), SH rest of band 3
// (21 floats; only at degree 3) and one edit-tint word. Splitting SH rest by band keeps
// the widest array at 96 B per slot. Core and SH are held in slot chunks of chunk_slots
// slots, one buffer per chunk, so that each fits one storage binding (splat_memory_plan.h;
// one chunk whenever the whole array fits). A contiguous write is one ranged copy per
// buffer and chunk it touches.
//
// Input checks: a slot range past the capacity is an error (nothing written). A Gaussian
// with a NaN/Inf in any field the splat math reads (splat_math.h step 0) is never
// uploaded: its slot is cleared instead and counted in rejected_nonfinite(); the other
// Gaussians of the same write are stored normally.
//
// Synchronisation: frames in flight may be reading the slots, so every write is packed
// straight into the staging ring of the owner's StagedUploads and copied by the GPU at
// the start of the next recorded frame (in write order). The CPU-side bookkeeping
// (occupancy, high-water mark, tint count) changes at once and describes the slots as
// the next frame will see them.
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/result.h"
#include "gauss/render/splat_math.h"
#include "gauss/render/vk_buffer.h"

namespace gauss::vk {
class Context;
class StagedUploads;
}

namespace gauss::render {

// How a SlotBuffer lays slots out, as a value: enough to pack Gaussians into its GPU layout
// anywhere (another thread, a buffer of the caller's) without touching the SlotBuffer.
struct SlotLayout {
  std::uint32_t capacity{0};
  std::uint32_t chunk_slots{1};
  int sh_degree{0};
  std::uint32_t sh_stride{0};       // floats per slot, bands 1-2
  std::uint32_t sh_high_stride{0};  // floats per slot, band 3
  std::uint32_t core_bytes() const noexcept;
  std::uint32_t sh_bytes() const noexcept { return sh_stride * 4u; }
  std::uint32_t sh_high_bytes() const noexcept { return sh_high_stride * 4u; }
  std::uint32_t bytes_per_slot() const noexcept { return core_bytes() + sh_bytes() + sh_high_bytes(); }
  bool operator==(const SlotLayout&) const = default;
};

// Packs `gaussians` into the GPU layout: core records at `core`, SH bands at `sh` and
// `sh_high` (each may be null when its stride is 0), one flag per Gaussian at `good` (1 =
// stored, 0 = refused for a non-finite field: its bytes are all zero, an empty slot).
// Thread-safe: reads only its arguments. Returns the number refused.
std::uint32_t pack_slots(const SlotLayout& layout, std::span<const Gaussian> gaussians, std::byte* core,
                         std::byte* sh, std::byte* sh_high, std::uint8_t* good);

// Slots packed by pack_slots into a caller's host-visible buffer: slots
// [first_slot, first_slot + count) of one slot chunk, their core bytes at `core_at` in the
// source buffer, SH bands at `sh_at` / `sh_high_at`; `good` indexes the run's flags.
struct PackedSlotRun {
  std::uint32_t first_slot{0};
  std::uint32_t count{0};
  VkDeviceSize core_at{0};
  VkDeviceSize sh_at{0};
  VkDeviceSize sh_high_at{0};
  std::uint32_t good_at{0};
};

struct SlotBufferCreateInfo {
  std::uint32_t capacity{0};  // slots, 1 ..; limited by the binding range (see create)
  int sh_degree{0};           // 0..3: SH rest stored up to this degree
  // Slots per chunk of core and SH (slot_chunk_slots()); 0 = as the device's binding range
  // needs.
  std::uint32_t chunk_slots{0};
};

class SlotBuffer {
 public:
  // Errors: capacity 0, sh_degree outside 0..3, more than kMaxSlotChunks chunks or a
  // chunk past the device's maxStorageBufferRange (the message gives the numbers),
  // allocation.
  // `uploads` carries every later write and must outlive the SlotBuffer.
  static Expected<SlotBuffer> create(vk::Context& context, const SlotBufferCreateInfo& info,
                                     vk::StagedUploads& uploads);

  SlotBuffer() = default;
  SlotBuffer(SlotBuffer&&) noexcept = default;
  SlotBuffer& operator=(SlotBuffer&&) noexcept = default;

  std::uint32_t capacity() const noexcept { return capacity_; }
  int sh_degree() const noexcept { return sh_degree_; }
  // Floats per slot of the bands 1-2 SH buffer (0 for degree 0; the preprocess shader's
  // SH_STRIDE). The band-3 buffer always holds SPLAT_SH_HIGH_STRIDE per slot at degree 3.
  std::uint32_t sh_stride() const noexcept { return sh_stride_; }
  // One past the highest occupied slot: the preprocess dispatch covers [0, high_water).
  std::uint32_t high_water() const noexcept { return high_water_; }
  std::uint32_t occupied_count() const noexcept { return occupied_count_; }
  bool occupied(std::uint32_t slot) const noexcept { return slot < capacity_ && occupied_[slot] != 0; }
  // Gaussians refused for non-finite values since creation.
  std::uint64_t rejected_nonfinite() const noexcept { return rejected_nonfinite_; }

  // Writes gaussians[i] to slot first_slot + i (one ranged copy per buffer).
  Status write_slots(std::uint32_t first_slot, std::span<const Gaussian> gaussians);
  Status write_slot(SlotIndex slot, const Gaussian& gaussian) {
    return write_slots(to_underlying(slot), std::span<const Gaussian>(&gaussian, 1));
  }
  // Queues copies of runs packed elsewhere (pack_slots with layout()) from `source` into
  // the slots, in order with the other writes; `good` holds the runs' flags. The caller
  // keeps `source` unchanged until the frame that records the copies has finished. Costs
  // the calling thread O(runs) plus one byte per slot of bookkeeping, no packing.
  // Errors: a run past the capacity or across a chunk, a layout other than layout(),
  // flags or source bytes out of range (nothing queued).
  Status queue_packed(const vk::Buffer& source, const SlotLayout& packed_as, std::span<const PackedSlotRun> runs,
                      std::span<const std::uint8_t> good);
  SlotLayout layout() const noexcept {
    return {capacity_, chunk_slots_, sh_degree_, sh_stride_, sh_high_stride_};
  }
  // Marks [first_slot, first_slot + count) empty (and their edit tint None).
  Status clear_slots(std::uint32_t first_slot, std::uint32_t count);
  Status clear_slot(SlotIndex slot) { return clear_slots(to_underlying(slot), 1); }

  // Edit-visualisation state of slots [first, first + count), as of display frame `frame`
  // (the age counts from there): one staged write for the run. Errors: slots out of
  // range, an unknown tint kind (nothing changed).
  Status set_edit_tints(std::uint32_t first, std::uint32_t count, EditTintState state, std::uint32_t frame);
  Status set_edit_tint(std::uint32_t slot, EditTintState state, std::uint32_t frame) {
    return set_edit_tints(slot, 1, state, frame);
  }
  // Number of slots whose tint kind is not None (the renderer specialises tints away at 0).
  std::uint32_t tinted_count() const noexcept { return tinted_count_; }

  // Slot chunks: chunk c holds slots [c * chunk_slots(), min(capacity, (c + 1) * chunk_slots())).
  std::uint32_t chunk_count() const noexcept { return static_cast<std::uint32_t>(core_.size()); }
  std::uint32_t chunk_slots() const noexcept { return chunk_slots_; }
  const vk::Buffer& core_buffer(std::uint32_t chunk) const noexcept { return core_[chunk]; }
  const vk::Buffer& sh_buffer(std::uint32_t chunk) const noexcept { return sh_[chunk]; }  // 16 dummy bytes for degree 0
  const vk::Buffer& sh_high_buffer(std::uint32_t chunk) const noexcept { return sh_high_[chunk]; }  // 16 dummy bytes below degree 3
  const vk::Buffer& edit_buffer() const noexcept { return edit_; }  // every slot

 private:
  Status check_range(std::uint32_t first_slot, std::uint64_t count, const char* what) const;
  // Packs gaussians into slots [first_slot, first_slot + size) of one chunk.
  Status write_chunk_run(std::uint32_t first_slot, std::span<const Gaussian> gaussians);
  void set_occupied(std::uint32_t slot, bool value);
  std::vector<VkBufferCopy> regions_;  // queue_packed's scratch

  vk::StagedUploads* uploads_{nullptr};
  std::uint32_t capacity_{0};
  std::uint32_t chunk_slots_{0};
  int sh_degree_{0};
  std::uint32_t sh_stride_{0};
  std::uint32_t sh_high_stride_{0};
  std::uint32_t high_water_{0};
  std::uint32_t occupied_count_{0};
  std::uint32_t tinted_count_{0};
  std::uint64_t rejected_nonfinite_{0};
  std::vector<std::uint8_t> occupied_;
  std::vector<std::uint8_t> tinted_;
  std::vector<vk::Buffer> core_;     // one per chunk
  std::vector<vk::Buffer> sh_;
  std::vector<vk::Buffer> sh_high_;
  vk::Buffer edit_;
};

}  // namespace gauss::render
