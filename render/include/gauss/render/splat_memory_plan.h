#pragma once
// gauss::render::plan_splat_memory: what a SplatRenderer of a given create info needs on a
// device, worked out before anything is allocated, so that a scene too large for the
// device is refused with the numbers and nothing half made.
//
// The renderer has no fixed capacity. Its limits are the device's:
//  - maxStorageBufferRange (128 MiB on lavapipe): the wide per-slot arrays (core 64 B,
//    SH bands 1-2 up to 96 B, SH band 3 84 B, projected 64 B per slot) are split into at
//    most kMaxSlotChunks bindings of a power-of-two number of slots once one of them
//    would not fit one binding; the 4-byte per-slot arrays and the sort buffers are never
//    split, so they must fit one binding each;
//  - maxMemoryAllocationSize per buffer (one allocation per buffer);
//  - the device-local heap: every buffer the renderer makes, in total.
// On lavapipe (128 MiB bindings, 2 GiB heap) that is 4,194,304 slots at SH degree 3 and
// 8,388,608 at degree 0 (the binding limit; the heap comes next); with 4 GiB bindings
// (desktop GPUs) the heap decides. Buffers made later (mesh chunks, the staging ring for
// slot writes) are not part of the plan.
#include <cstdint>
#include <string>

#include "gauss/engine/result.h"

namespace gauss::vk {
class Context;
}

namespace gauss::render {

struct SplatRendererCreateInfo;

// Most bindings one per-slot array is split over (splat_layout.h SPLAT_MAX_SLOT_CHUNKS).
inline constexpr std::uint32_t kMaxSlotChunks = 4;

// One view's scratch, as SplatRenderer allocates it (its ViewScratch) and the plan counts it:
// projected splats (split like the other wide per-slot arrays), tile counts and offsets per
// slot, two sort key and two sort value buffers, the radix histogram, tile depth and the
// output pixels.
struct ViewScratchBytes {
  std::uint64_t projected_per_slot{0};
  std::uint64_t tile_counts{0};
  std::uint64_t offsets{0};
  std::uint64_t sort_buffer{0};  // each of keys A, keys B, values A, values B
  std::uint64_t histogram{0};
  std::uint64_t tile_depth{0};
  std::uint64_t output{0};
  std::uint64_t total(std::uint64_t capacity) const {
    return projected_per_slot * capacity + tile_counts + offsets + 4 * sort_buffer + histogram + tile_depth + output;
  }
};

struct SplatMemoryPlan {
  std::uint32_t capacity{0};
  std::uint32_t max_pairs{0};     // max_pairs after the automatic choice
  std::uint32_t slot_chunks{1};   // bindings each wide per-slot array is split over
  std::uint32_t chunk_slots{0};   // slots per chunk (the capacity when slot_chunks is 1)
  std::uint64_t binding_range{0}; // bytes one binding may cover (device limit or the override)
  std::uint64_t bytes_per_slot{0};  // every buffer that grows with the capacity, per slot
  std::uint64_t total_bytes{0};     // every buffer and target the renderer makes
  // A view's scratch; total_bytes counts the first view's.
  ViewScratchBytes view_scratch;
  std::uint64_t heap_bytes{0};      // the device-local heap
  std::uint64_t max_allocation{0};  // maxMemoryAllocationSize
  // The second view's scratch, made beside total_bytes at the first frame whose two views
  // are recorded together (SplatPassProfile::views_together); never made otherwise.
  std::uint64_t second_view_bytes() const { return view_scratch.total(capacity); }
};

// Slots per chunk of the wide per-slot arrays for `capacity` slots at `sh_degree` with
// bindings of `binding_range` bytes: the capacity itself when every array fits one
// binding, else the largest power of two whose widest array fits. 0 when not even one
// slot fits (a binding under 96 bytes).
std::uint32_t slot_chunk_slots(std::uint64_t binding_range, std::uint32_t capacity, int sh_degree);

// Bytes of the radix histogram for sorts of up to `sort_keys` keys: 16 words per block of
// the smaller radix block of the two pass shapes (SORT_BLOCK_GPU), so one size serves
// both; the GPU scans keep their block sums there too.
std::uint64_t radix_histogram_bytes(std::uint64_t sort_keys);

// What a plan is made against: a device's limits (splat_device_limits), or limits a test
// makes up for a device it does not have.
struct SplatDeviceLimits {
  std::string name;
  std::uint64_t binding_range{0};   // maxStorageBufferRange
  std::uint64_t heap_bytes{0};      // the largest device-local heap (the largest heap if none is)
  std::uint64_t max_allocation{0};  // maxMemoryAllocationSize
};
SplatDeviceLimits splat_device_limits(const vk::Context& context);

// Errors (one message naming the limit, what the renderer needs and the most slots the
// device takes at this SH degree and size): invalid fields of `info` (as
// SplatRenderer::create), more chunks than kMaxSlotChunks, a 4-byte-per-slot or sort
// buffer past one binding, a buffer past maxMemoryAllocationSize, a total past the heap.
// Automatic pairs (`info.max_pairs` 0): 16 per slot, at least 2^20; up to 2^25 they count
// towards what the capacity needs (lavapipe's binding holds 2^25), and beyond that, where
// the bindings hold more, they take at most half of the heap the rest of the plan leaves
// free, so they never decide whether a capacity fits. `grow_pairs_to` asks for more pairs
// than 16 per slot (a renderer whose view needed more grows its sort buffers): as many of
// them as the same bounds allow.
Expected<SplatMemoryPlan> plan_splat_memory(const SplatDeviceLimits& device, const SplatRendererCreateInfo& info,
                                            std::uint64_t grow_pairs_to = 0);
Expected<SplatMemoryPlan> plan_splat_memory(const vk::Context& context, const SplatRendererCreateInfo& info);

// The largest capacity plan_splat_memory accepts with the other fields of `info`
// (0 when none does).
std::uint32_t max_splat_capacity(const SplatDeviceLimits& device, const SplatRendererCreateInfo& info);
std::uint32_t max_splat_capacity(const vk::Context& context, const SplatRendererCreateInfo& info);

}  // namespace gauss::render
