// SlotBuffer: packing of gauss::Gaussian into the GPU layout of shaders/shared/splat_layout.h
// and ranged uploads into the stable-slot buffers.
#include "gauss/render/slot_buffer.h"

#include <algorithm>
#include <cstring>
#include <string>

#include "gauss/render/reference_rasterizer.h"
#include "gauss/render/splat_memory_plan.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_staged_uploads.h"
#include "splat_layout.h"

namespace gauss::render {

namespace {

gpu::GpuSplatCore pack_core(const Gaussian& g) {
  gpu::GpuSplatCore c{};
  c.position_opacity = glm::vec4(g.position, g.opacity_logit);
  c.rotation = g.rotation;
  c.log_scale_dc_r = glm::vec4(g.log_scale, g.sh_dc.x);
  c.dc_gb = glm::vec2(g.sh_dc.y, g.sh_dc.z);
  c.object = to_underlying(g.object);
  c.flags = gpu::SPLAT_FLAG_OCCUPIED;
  return c;
}

std::uint32_t edit_word(EditTintState state, std::uint32_t frame) {
  // Every age past the longest fade behaves alike; clamping keeps the 30-bit difference exact.
  const std::uint32_t age = std::min<std::uint32_t>(state.age, 1u << 20);
  const std::uint32_t edit_frame = (frame - age) & gpu::SPLAT_EDIT_FRAME_MASK;
  return (static_cast<std::uint32_t>(state.kind) << gpu::SPLAT_EDIT_KIND_SHIFT) | edit_frame;
}

}  // namespace

std::uint32_t SlotLayout::core_bytes() const noexcept { return sizeof(gpu::GpuSplatCore); }

std::uint32_t pack_slots(const SlotLayout& layout, std::span<const Gaussian> gaussians, std::byte* core,
                         std::byte* sh, std::byte* sh_high, std::uint8_t* good) {
  const auto n = static_cast<std::uint32_t>(gaussians.size());
  auto* cores = reinterpret_cast<gpu::GpuSplatCore*>(core);
  std::uint32_t refused = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    good[i] = gaussian_is_finite(gaussians[i], layout.sh_degree) ? 1 : 0;
    if (!good[i]) {
      ++refused;
      cores[i] = gpu::GpuSplatCore{};
      continue;
    }
    cores[i] = pack_core(gaussians[i]);
  }
  // One SH band buffer: `stride` floats per slot, coefficients from `first_coeff` on.
  auto pack_band = [&](std::byte* bytes, std::uint32_t stride, std::uint32_t first_coeff) {
    if (stride == 0 || bytes == nullptr) return;
    auto* band = reinterpret_cast<float*>(bytes);
    for (std::uint32_t i = 0; i < n; ++i) {
      float* out = band + std::size_t{i} * stride;
      if (!good[i]) {
        std::fill(out, out + stride, 0.0f);
        continue;
      }
      for (std::uint32_t k = 0; k < stride / 3; ++k)
        for (std::uint32_t ch = 0; ch < 3; ++ch)
          out[k * 3 + ch] = gaussians[i].sh_rest[first_coeff + k][static_cast<int>(ch)];
    }
  };
  pack_band(sh, layout.sh_stride, 0);
  pack_band(sh_high, layout.sh_high_stride, gpu::SPLAT_SH_LOW_COEFFS);
  return refused;
}

Expected<SlotBuffer> SlotBuffer::create(vk::Context& context, const SlotBufferCreateInfo& info,
                                        vk::StagedUploads& uploads) {
  if (info.capacity == 0) return Error{"SlotBuffer: capacity must be at least 1"};
  if (info.sh_degree < 0 || info.sh_degree > kMaxShDegree)
    return Error{"SlotBuffer: sh_degree " + std::to_string(info.sh_degree) + " outside 0..3"};
  SlotBuffer s;
  s.uploads_ = &uploads;
  s.capacity_ = info.capacity;
  s.sh_degree_ = info.sh_degree;
  const auto coeffs = static_cast<std::uint32_t>(sh_rest_count(info.sh_degree));
  s.sh_stride_ = 3u * std::min(coeffs, gpu::SPLAT_SH_LOW_COEFFS);
  s.sh_high_stride_ = coeffs > gpu::SPLAT_SH_LOW_COEFFS ? gpu::SPLAT_SH_HIGH_STRIDE : 0u;
  const VkDeviceSize range = context.max_storage_buffer_range();
  s.chunk_slots_ = info.chunk_slots != 0 ? std::min(info.chunk_slots, info.capacity)
                                         : slot_chunk_slots(range, info.capacity, info.sh_degree);
  const std::uint64_t chunks = s.chunk_slots_ == 0 ? 0 : (std::uint64_t{info.capacity} + s.chunk_slots_ - 1) / s.chunk_slots_;
  const VkDeviceSize widest = std::max<VkDeviceSize>(sizeof(gpu::GpuSplatCore), s.sh_stride_ * sizeof(float));
  if (chunks == 0 || chunks > kMaxSlotChunks || VkDeviceSize{s.chunk_slots_} * widest > range)
    return Error{"SlotBuffer: capacity " + std::to_string(info.capacity) + " at SH degree " +
                 std::to_string(info.sh_degree) + " in chunks of " + std::to_string(s.chunk_slots_) +
                 " slots needs " + std::to_string(chunks) + " chunks of up to " +
                 std::to_string(VkDeviceSize{s.chunk_slots_} * widest) + " bytes; the device's storage binding range is " +
                 std::to_string(range) + " bytes and at most " + std::to_string(kMaxSlotChunks) + " chunks are bound"};

  for (std::uint32_t c = 0; c < chunks; ++c) {
    const std::uint32_t first = c * s.chunk_slots_;
    const VkDeviceSize n = std::min(info.capacity - first, s.chunk_slots_);
    const std::string part = chunks > 1 ? " chunk " + std::to_string(c) : std::string{};
    auto core = vk::Buffer::create(context, {.size = n * sizeof(gpu::GpuSplatCore), .name = "splat core slots" + part});
    if (!core) return core.error();
    auto sh = vk::Buffer::create(context, {.size = std::max<VkDeviceSize>(16, n * s.sh_stride_ * sizeof(float)),
                                           .name = "splat SH rest slots (bands 1-2)" + part});
    if (!sh) return sh.error();
    auto sh_high = vk::Buffer::create(context, {.size = std::max<VkDeviceSize>(16, n * s.sh_high_stride_ * sizeof(float)),
                                                .name = "splat SH rest slots (band 3)" + part});
    if (!sh_high) return sh_high.error();
    // Start empty: flags 0 everywhere.
    std::vector<gpu::GpuSplatCore> empty(std::min<VkDeviceSize>(n, 65536u));
    for (VkDeviceSize at = 0; at < n; at += empty.size()) {
      const VkDeviceSize m = std::min<VkDeviceSize>(n - at, empty.size());
      if (auto st = core->upload(empty.data(), m * sizeof(gpu::GpuSplatCore), at * sizeof(gpu::GpuSplatCore)); !st)
        return st.error();
    }
    s.core_.push_back(std::move(*core));
    s.sh_.push_back(std::move(*sh));
    s.sh_high_.push_back(std::move(*sh_high));
  }
  auto edit = vk::Buffer::create(context, {.size = VkDeviceSize{info.capacity} * 4, .name = "splat edit tints"});
  if (!edit) return edit.error();
  s.edit_ = std::move(*edit);
  s.occupied_.assign(info.capacity, 0);
  s.tinted_.assign(info.capacity, 0);
  // Tints None.
  std::vector<std::uint32_t> zero_words(info.capacity, 0u);
  if (auto st = s.edit_.upload(zero_words.data(), VkDeviceSize{info.capacity} * 4); !st) return st.error();
  return s;
}

Status SlotBuffer::check_range(std::uint32_t first_slot, std::uint64_t count, const char* what) const {
  if (std::uint64_t{first_slot} + count > capacity_)
    return Error{std::string("SlotBuffer::") + what + ": slots [" + std::to_string(first_slot) + ", " +
                 std::to_string(std::uint64_t{first_slot} + count) + ") exceed the capacity " +
                 std::to_string(capacity_)};
  return Ok{};
}

void SlotBuffer::set_occupied(std::uint32_t slot, bool value) {
  if ((occupied_[slot] != 0) == value) return;
  occupied_[slot] = value ? 1 : 0;
  if (value) {
    ++occupied_count_;
    high_water_ = std::max(high_water_, slot + 1);
  } else {
    --occupied_count_;
    while (high_water_ > 0 && occupied_[high_water_ - 1] == 0) --high_water_;
  }
}

Status SlotBuffer::write_slots(std::uint32_t first_slot, std::span<const Gaussian> gaussians) {
  if (auto st = check_range(first_slot, gaussians.size(), "write_slots"); !st) return st;
  // One run per chunk the range touches (one run in all below one binding's worth of
  // slots). Only a staging failure can stop a later run, after the earlier ones are queued.
  while (!gaussians.empty()) {
    const std::uint64_t chunk_end = (std::uint64_t{first_slot} / chunk_slots_ + 1) * chunk_slots_;
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(gaussians.size(), chunk_end - first_slot));
    if (auto st = write_chunk_run(first_slot, gaussians.first(n)); !st) return st;
    first_slot += static_cast<std::uint32_t>(n);
    gaussians = gaussians.subspan(n);
  }
  return Ok{};
}

Status SlotBuffer::write_chunk_run(std::uint32_t first_slot, std::span<const Gaussian> gaussians) {
  const auto n = static_cast<std::uint32_t>(gaussians.size());
  const std::uint32_t chunk = first_slot / chunk_slots_;
  const std::uint32_t at = first_slot - chunk * chunk_slots_;
  // Staging for every buffer first, so a failure leaves nothing half queued; then pack
  // straight into it. A refused Gaussian stays all zero there (an empty slot).
  auto reserve = [&](const vk::Buffer& buffer, std::uint32_t bytes_per_slot) -> Expected<std::span<std::byte>> {
    if (bytes_per_slot == 0) return std::span<std::byte>{};
    auto r = uploads_->reserve(buffer, VkDeviceSize{at} * bytes_per_slot, VkDeviceSize{n} * bytes_per_slot);
    if (!r) return Error{"SlotBuffer::write_slots: " + r.message()};
    return r;
  };
  auto core = reserve(core_[chunk], sizeof(gpu::GpuSplatCore));
  if (!core) return core.error();
  auto sh = reserve(sh_[chunk], sh_stride_ * sizeof(float));
  if (!sh) return sh.error();
  auto sh_high = reserve(sh_high_[chunk], sh_high_stride_ * sizeof(float));
  if (!sh_high) return sh_high.error();

  std::vector<std::uint8_t> good(n, 0);
  rejected_nonfinite_ += pack_slots(layout(), gaussians, core->data(), sh->data(), sh_high->data(), good.data());
  for (std::uint32_t i = 0; i < n; ++i) set_occupied(first_slot + i, good[i] != 0);
  return Ok{};
}

Status SlotBuffer::queue_packed(const vk::Buffer& source, const SlotLayout& packed_as,
                                std::span<const PackedSlotRun> runs, std::span<const std::uint8_t> good) {
  if (!(packed_as == layout())) return Error{"SlotBuffer::queue_packed: runs packed for another slot layout"};
  for (const PackedSlotRun& r : runs) {
    if (auto st = check_range(r.first_slot, r.count, "queue_packed"); !st) return st;
    if (r.count > 0 && r.first_slot / chunk_slots_ != (r.first_slot + r.count - 1) / chunk_slots_)
      return Error{"SlotBuffer::queue_packed: run [" + std::to_string(r.first_slot) + ", " +
                   std::to_string(r.first_slot + r.count) + ") crosses a slot chunk"};
    if (std::uint64_t{r.good_at} + r.count > good.size())
      return Error{"SlotBuffer::queue_packed: run flags past the " + std::to_string(good.size()) + " given"};
    const VkDeviceSize n = r.count;
    if (r.core_at + n * layout().core_bytes() > source.size() || r.sh_at + n * layout().sh_bytes() > source.size() ||
        r.sh_high_at + n * layout().sh_high_bytes() > source.size())
      return Error{"SlotBuffer::queue_packed: run of " + std::to_string(r.count) + " slots past the end of '" +
                   source.name() + "' (" + std::to_string(source.size()) + " bytes)"};
  }
  // One copy group per destination buffer: runs are taken chunk by chunk, each chunk's
  // core, SH and band-3 regions together. StagedUploads checks every region's bytes.
  const std::uint32_t bytes[3] = {layout().core_bytes(), layout().sh_bytes(), layout().sh_high_bytes()};
  for (std::uint32_t chunk = 0; chunk < chunk_count(); ++chunk) {
    const vk::Buffer* dst[3] = {&core_[chunk], &sh_[chunk], &sh_high_[chunk]};
    for (int part = 0; part < 3; ++part) {
      if (bytes[part] == 0) continue;
      regions_.clear();
      for (const PackedSlotRun& r : runs) {
        if (r.count == 0 || r.first_slot / chunk_slots_ != chunk) continue;
        const VkDeviceSize src = part == 0 ? r.core_at : part == 1 ? r.sh_at : r.sh_high_at;
        regions_.push_back(VkBufferCopy{src, VkDeviceSize{r.first_slot - chunk * chunk_slots_} * bytes[part],
                                        VkDeviceSize{r.count} * bytes[part]});
      }
      if (regions_.empty()) break;
      if (auto st = uploads_->copy_from(source, *dst[part], regions_); !st)
        return Error{"SlotBuffer::queue_packed: " + st.message()};
    }
  }
  // Bookkeeping by run (this is the display thread's per-slot share): a run of stored
  // slots in one pass over its bytes, runs with a refusal slot by slot.
  for (const PackedSlotRun& r : runs) {
    if (r.count == 0) continue;
    const std::uint8_t* flags = good.data() + r.good_at;
    std::uint8_t* occ = occupied_.data() + r.first_slot;
    if (std::all_of(flags, flags + r.count, [](std::uint8_t f) { return f != 0; })) {
      occupied_count_ += static_cast<std::uint32_t>(std::count(occ, occ + r.count, std::uint8_t{0}));
      std::fill(occ, occ + r.count, std::uint8_t{1});
      high_water_ = std::max(high_water_, r.first_slot + r.count);
      continue;
    }
    for (std::uint32_t i = 0; i < r.count; ++i) {
      const bool ok = flags[i] != 0;
      if (!ok) ++rejected_nonfinite_;
      set_occupied(r.first_slot + i, ok);
    }
  }
  return Ok{};
}

Status SlotBuffer::clear_slots(std::uint32_t first_slot, std::uint32_t count) {
  if (auto st = check_range(first_slot, count, "clear_slots"); !st) return st;
  if (count == 0) return Ok{};
  for (std::uint32_t slot = first_slot; slot < first_slot + count;) {
    const std::uint32_t chunk = slot / chunk_slots_;
    const auto n = static_cast<std::uint32_t>(
        std::min<std::uint64_t>(std::uint64_t{first_slot} + count, (std::uint64_t{chunk} + 1) * chunk_slots_) - slot);
    auto core = uploads_->reserve(core_[chunk], VkDeviceSize{slot - chunk * chunk_slots_} * sizeof(gpu::GpuSplatCore),
                                  VkDeviceSize{n} * sizeof(gpu::GpuSplatCore));
    if (!core) return Error{"SlotBuffer::clear_slots: " + core.message()};
    std::memset(core->data(), 0, core->size());
    slot += n;
  }
  auto words = uploads_->reserve(edit_, VkDeviceSize{first_slot} * 4, VkDeviceSize{count} * 4);
  if (!words) return Error{"SlotBuffer::clear_slots: " + words.message()};
  std::memset(words->data(), 0, words->size());
  for (std::uint32_t i = 0; i < count; ++i) {
    set_occupied(first_slot + i, false);
    if (tinted_[first_slot + i] != 0) {
      tinted_[first_slot + i] = 0;
      --tinted_count_;
    }
  }
  return Ok{};
}

Status SlotBuffer::set_edit_tints(std::uint32_t first, std::uint32_t count, EditTintState state, std::uint32_t frame) {
  if (auto st = check_range(first, count, "set_edit_tints"); !st) return st;
  if (static_cast<std::uint32_t>(state.kind) > 3u) return Error{"SlotBuffer::set_edit_tints: unknown tint kind"};
  if (count == 0) return Ok{};
  const std::uint32_t word = state.kind == EditTintKind::None ? 0u : edit_word(state, frame);
  auto words = uploads_->reserve(edit_, VkDeviceSize{first} * 4, VkDeviceSize{count} * 4);
  if (!words) return Error{"SlotBuffer::set_edit_tints: " + words.message()};
  std::fill_n(reinterpret_cast<std::uint32_t*>(words->data()), count, word);
  const std::uint8_t tinted = state.kind != EditTintKind::None ? 1 : 0;
  for (std::uint32_t slot = first; slot < first + count; ++slot) {
    if (tinted_[slot] == tinted) continue;
    tinted_[slot] = tinted;
    if (tinted) ++tinted_count_;
    else --tinted_count_;
  }
  return Ok{};
}

}  // namespace gauss::render
