// plan_splat_memory: the renderer's buffers, sized from the create info alone (the same
// sizes SplatRenderer::create and SlotBuffer::create then allocate), checked against the
// device's binding range, allocation size and heap before anything is made.
#include "gauss/render/splat_memory_plan.h"

#include <algorithm>
#include <bit>
#include <string>
#include <vector>

#include "gauss/engine/log_text.h"
#include "gauss/render/splat_math.h"
#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_frame_ring.h"
#include "splat_layout.h"

namespace gauss::render {

static_assert(kMaxSlotChunks == gpu::SPLAT_MAX_SLOT_CHUNKS);

namespace {

// Bytes per slot of each wide (chunked) per-slot array.
struct WideStrides {
  std::uint64_t core{sizeof(gpu::GpuSplatCore)};
  std::uint64_t sh{0};       // bands 1-2
  std::uint64_t sh_high{0};  // band 3
  std::uint64_t projected{sizeof(gpu::GpuProjected)};
  std::uint64_t widest() const { return std::max({core, sh, sh_high, projected}); }
  std::uint64_t sum() const { return core + sh + sh_high + projected; }
};

WideStrides wide_strides(int sh_degree) {
  WideStrides w;
  const auto coeffs = static_cast<std::uint32_t>(sh_rest_count(sh_degree));
  w.sh = 3u * std::min(coeffs, gpu::SPLAT_SH_LOW_COEFFS) * sizeof(float);
  w.sh_high = coeffs > gpu::SPLAT_SH_LOW_COEFFS ? gpu::SPLAT_SH_HIGH_STRIDE * sizeof(float) : 0u;
  return w;
}

// Per-slot arrays of 4 bytes (edit tints, tile counts, offsets), never split.
constexpr std::uint64_t kNarrowBytesPerSlot = 3 * 4;

std::string with_commas(std::uint64_t n) {
  // Built forward (g++ 12 warns falsely, -Wrestrict, on std::string::insert inlined here).
  const std::string digits = std::to_string(n);
  std::string s;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) s += ',';
    s += digits[i];
  }
  return s;
}

struct Checked {
  SplatMemoryPlan plan;
  std::string problem;  // empty when the plan fits the device
};

// The bytes one binding may cover: the device's, or less where the create info says.
std::uint64_t binding_range_of(const SplatDeviceLimits& device, const SplatRendererCreateInfo& info) {
  return info.max_binding_bytes != 0 ? std::min(device.binding_range, info.max_binding_bytes) : device.binding_range;
}

// The plan for `info` with `max_pairs` (tile, splat) pairs per view and, when the device
// cannot hold it, what is wrong (without the "at most N slots" part, which needs this
// function again).
Checked check_with_pairs(const SplatDeviceLimits& device, const SplatRendererCreateInfo& info, std::uint32_t max_pairs) {
  Checked out;
  SplatMemoryPlan& p = out.plan;
  p.capacity = info.capacity;
  p.binding_range = binding_range_of(device, info);
  p.heap_bytes = device.heap_bytes;
  p.max_allocation = device.max_allocation;
  const std::uint64_t range = p.binding_range;
  const std::uint64_t cap = info.capacity;

  const std::uint64_t pair_limit = range / 4;
  p.max_pairs = max_pairs;
  if (p.max_pairs > pair_limit) {
    out.problem = "max_pairs " + with_commas(p.max_pairs) + " needs " + with_commas(std::uint64_t{p.max_pairs} * 4) +
                  " bytes per sort buffer, more than one storage binding covers (" + with_commas(range) + " bytes, " +
                  with_commas(pair_limit) + " pairs)";
    return out;
  }

  const WideStrides wide = wide_strides(info.sh_degree);
  p.chunk_slots = slot_chunk_slots(range, info.capacity, info.sh_degree);
  if (p.chunk_slots == 0) {
    out.problem = "one storage binding covers " + with_commas(range) + " bytes, less than one slot's " +
                  with_commas(wide.widest()) + " bytes";
    return out;
  }
  const std::uint64_t chunks = (cap + p.chunk_slots - 1) / p.chunk_slots;
  p.slot_chunks = static_cast<std::uint32_t>(std::min<std::uint64_t>(chunks, 0xFFFFFFFFu));
  const std::uint64_t sort_items = std::max<std::uint64_t>(cap, p.max_pairs);
  const std::uint64_t sort_bytes = sort_items * 4;
  p.bytes_per_slot = wide.sum() + kNarrowBytesPerSlot;
  const std::uint64_t max_tiles = std::uint64_t{tile_count(info.max_width)} * tile_count(info.max_height);
  const std::uint64_t pixels = std::uint64_t{info.max_width} * info.max_height;
  ViewScratchBytes& vs = p.view_scratch;
  vs.projected_per_slot = wide.projected;
  vs.tile_counts = cap * 4;
  vs.offsets = cap * 4;
  vs.sort_buffer = sort_bytes;
  vs.histogram = radix_histogram_bytes(sort_items);
  vs.tile_depth = max_tiles * 4;
  vs.output = pixels * 4;
  // bytes_per_slot holds the scratch's per-slot arrays (projected, tile counts, offsets);
  // beside them the scratch's sort buffers, histogram, tile depth and output pixels,
  // highlight ids, two views' tile ranges and targets (RGBA8 + D32), per-frame constants.
  const std::uint64_t fixed = 4 * vs.sort_buffer + vs.histogram + vs.tile_depth + vs.output + kMaxHighlightObjects * 4 +
                              2 * max_tiles * 8 + 2 * pixels * 8 +
                              std::uint64_t{info.frames_in_flight} * 2 * (sizeof(gpu::GpuView) + gpu::SPLAT_COUNTER_WORDS * 4);
  p.total_bytes = p.bytes_per_slot * cap + fixed;

  if (chunks > kMaxSlotChunks) {
    out.problem = with_commas(cap) + " slots need " + std::to_string(chunks) + " storage bindings of " + with_commas(p.chunk_slots) +
                  " slots per wide per-slot array (" + with_commas(wide.widest()) + " bytes per slot in the widest, " +
                  "maxStorageBufferRange " + with_commas(range) + " bytes), more than the " + std::to_string(kMaxSlotChunks) +
                  " the passes bind";
    return out;
  }
  if (sort_bytes > range) {  // sort_items >= capacity: the 4-byte per-slot arrays fit too
    out.problem = "the sort buffers need " + with_commas(sort_bytes) + " bytes (4 bytes x " + with_commas(sort_items) +
                  " keys) in one storage binding, more than maxStorageBufferRange " + with_commas(range) + " bytes";
    return out;
  }
  const std::uint64_t largest = std::max({std::uint64_t{p.chunk_slots} * wide.widest(), sort_bytes, pixels * 4});
  if (largest > p.max_allocation) {
    out.problem = "its largest buffer needs " + with_commas(largest) + " bytes, more than maxMemoryAllocationSize " +
                  with_commas(p.max_allocation) + " bytes";
    return out;
  }
  if (p.total_bytes > p.heap_bytes) {
    out.problem = "it needs " + format_bytes(p.total_bytes) + " (" + with_commas(p.bytes_per_slot) + " bytes per slot x " +
                  with_commas(cap) + " slots + " + format_bytes(fixed) + " for sorting and " +
                  std::to_string(info.max_width) + "x" + std::to_string(info.max_height) +
                  " targets), more than the device-local heap of " + format_bytes(p.heap_bytes);
    return out;
  }
  return out;
}

// Automatic pairs: 16 per slot, at least 1M. Up to 32M (kPairsAlwaysPlanned) they are part of
// what a capacity needs, as on lavapipe, whose 128 MiB binding holds 32M; past that a device
// with larger bindings gives them at most half of the heap the rest of the plan leaves free.
// A large scene on a GPU with room is then not cut at 32M pairs (a 16M-Gaussian scene at 1080p
// needs about 130M), and one on a tight heap is not refused for pairs it may never need: the
// capacities a device takes are those it took with 32M. A renderer whose view needed more
// pairs than that asks again with `grow_to`: beyond the 16 per slot (or 32M) the same half of
// the free heap bounds them.
constexpr std::uint64_t kPairsPerSlot = 16;
constexpr std::uint64_t kPairsAlwaysPlanned = 32u << 20;
constexpr std::uint64_t kPairsMost = 1u << 31;  // pair counts and offsets are 32-bit words

std::uint64_t pairs_per_slot(const SplatRendererCreateInfo& info) {
  return std::max<std::uint64_t>(1u << 20, std::uint64_t{info.capacity} * kPairsPerSlot);
}

// The pairs that count towards what the capacity needs: the asked ones, or the automatic
// ones up to kPairsAlwaysPlanned. Whether a capacity fits is decided with these alone.
std::uint32_t planned_pairs(const SplatDeviceLimits& device, const SplatRendererCreateInfo& info) {
  if (info.max_pairs != 0) return info.max_pairs;
  return static_cast<std::uint32_t>(
      std::min({binding_range_of(device, info) / 4, kPairsAlwaysPlanned, pairs_per_slot(info)}));
}

Checked check(const SplatDeviceLimits& device, const SplatRendererCreateInfo& info, std::uint64_t grow_to = 0) {
  const std::uint64_t floor = planned_pairs(device, info);
  Checked out = check_with_pairs(device, info, static_cast<std::uint32_t>(floor));
  if (info.max_pairs != 0) return out;
  const std::uint64_t most = std::min({binding_range_of(device, info) / 4, device.max_allocation / 4, kPairsMost,
                                       std::max(pairs_per_slot(info), grow_to)});
  if (!out.problem.empty() || most <= floor) return out;
  const std::uint64_t budget = out.plan.total_bytes + (out.plan.heap_bytes - out.plan.total_bytes) / 2;
  auto fits = [&](std::uint64_t pairs) {
    const Checked c = check_with_pairs(device, info, static_cast<std::uint32_t>(pairs));
    return c.problem.empty() && c.plan.total_bytes <= budget;
  };
  if (fits(most)) return check_with_pairs(device, info, static_cast<std::uint32_t>(most));
  std::uint64_t lo = floor, hi = most;  // fits(lo), !fits(hi): the needs grow with the pairs
  while (hi - lo > 1) {
    const std::uint64_t mid = lo + (hi - lo) / 2;
    (fits(mid) ? lo : hi) = mid;
  }
  return check_with_pairs(device, info, static_cast<std::uint32_t>(lo));
}

// The create-info checks that do not depend on the device (SplatRenderer::create's).
Status check_fields(const SplatRendererCreateInfo& info) {
  if (info.capacity == 0) return Error{"SplatRenderer: capacity must be at least 1"};
  if (info.sh_degree < 0 || info.sh_degree > kMaxShDegree)
    return Error{"SplatRenderer: sh_degree " + std::to_string(info.sh_degree) + " outside 0..3"};
  if (info.max_width == 0 || info.max_height == 0 || info.max_width > 4096 || info.max_height > 4096)
    return Error{"SplatRenderer: max size " + std::to_string(info.max_width) + "x" + std::to_string(info.max_height) +
                 " outside 1..4096"};
  if (info.frames_in_flight == 0 || info.frames_in_flight > vk::kMaxFramesInFlight)
    return Error{"SplatRenderer: frames_in_flight " + std::to_string(info.frames_in_flight) + " outside 1.." +
                 std::to_string(vk::kMaxFramesInFlight)};
  return Ok{};
}

}  // namespace

std::uint64_t radix_histogram_bytes(std::uint64_t sort_keys) {
  // The widest digit's bins per block, then one total per digit (sort_radix_offsets_gpu.comp).
  return (std::uint64_t{gpu::SORT_BINS_MAX} * ((sort_keys + gpu::SORT_BLOCK_GPU - 1) / gpu::SORT_BLOCK_GPU) +
          gpu::SORT_BINS_MAX) * 4;
}

std::uint32_t slot_chunk_slots(std::uint64_t binding_range, std::uint32_t capacity, int sh_degree) {
  const std::uint64_t widest = wide_strides(sh_degree).widest();
  if (std::uint64_t{capacity} * widest <= binding_range) return capacity;
  const std::uint64_t fit = binding_range / widest;
  if (fit == 0) return 0;
  return static_cast<std::uint32_t>(std::bit_floor(std::min<std::uint64_t>(fit, 1u << 31)));
}

SplatDeviceLimits splat_device_limits(const vk::Context& context) {
  SplatDeviceLimits d;
  d.name = context.device_name();
  d.binding_range = context.max_storage_buffer_range();
  d.max_allocation = context.max_memory_allocation_size();
  const VkPhysicalDeviceMemoryProperties& m = context.memory_properties();
  for (std::uint32_t h = 0; h < m.memoryHeapCount; ++h)
    if (m.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)
      d.heap_bytes = std::max<std::uint64_t>(d.heap_bytes, m.memoryHeaps[h].size);
  if (d.heap_bytes == 0)
    for (std::uint32_t h = 0; h < m.memoryHeapCount; ++h) d.heap_bytes = std::max<std::uint64_t>(d.heap_bytes, m.memoryHeaps[h].size);
  return d;
}

std::uint32_t max_splat_capacity(const SplatDeviceLimits& device, const SplatRendererCreateInfo& info) {
  SplatRendererCreateInfo probe = info;
  auto fits = [&](std::uint32_t capacity) {
    probe.capacity = capacity;
    return check_with_pairs(device, probe, planned_pairs(device, probe)).problem.empty();
  };
  if (!check_fields({.capacity = 1,
                     .sh_degree = info.sh_degree,
                     .max_width = info.max_width,
                     .max_height = info.max_height,
                     .frames_in_flight = info.frames_in_flight})
           .ok() ||
      !fits(1))
    return 0;
  // Every need grows with the capacity, so the capacities that fit are 1 .. the answer.
  std::uint32_t lo = 1, hi = 0xFFFFFFFFu;
  if (fits(hi)) return hi;
  while (hi - lo > 1) {
    const std::uint32_t mid = lo + (hi - lo) / 2;
    (fits(mid) ? lo : hi) = mid;
  }
  return lo;
}

Expected<SplatMemoryPlan> plan_splat_memory(const SplatDeviceLimits& device, const SplatRendererCreateInfo& info,
                                            std::uint64_t grow_pairs_to) {
  if (auto st = check_fields(info); !st) return st.error();
  Checked c = check(device, info, grow_pairs_to);
  if (c.problem.empty()) return c.plan;
  const std::uint32_t most = max_splat_capacity(device, info);
  return Error{"SplatRenderer: " + with_commas(info.capacity) + " slots at SH degree " + std::to_string(info.sh_degree) +
               " do not fit device '" + device.name + "': " + c.problem + "; it holds at most " +
               with_commas(most) + " slots at this SH degree and " + std::to_string(info.max_width) + "x" +
               std::to_string(info.max_height)};
}

Expected<SplatMemoryPlan> plan_splat_memory(const vk::Context& context, const SplatRendererCreateInfo& info) {
  return plan_splat_memory(splat_device_limits(context), info);
}

std::uint32_t max_splat_capacity(const vk::Context& context, const SplatRendererCreateInfo& info) {
  return max_splat_capacity(splat_device_limits(context), info);
}

}  // namespace gauss::render
