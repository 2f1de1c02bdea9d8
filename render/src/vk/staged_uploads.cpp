// StagedUploads: the staging ring and the copy groups it feeds, each recorded as a buffer
// copy or a compute scatter (see the header).
#include "gauss/render/vk_staged_uploads.h"

#include <algorithm>
#include <cstring>
#include <iterator>
#include <optional>
#include <string>

#include "gauss/render/vk_commands.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_frame_ring.h"
#include "vk/upload_scatter.h"

namespace gauss::vk {

namespace {
constexpr VkDeviceSize kAlign = 16;
VkDeviceSize align_up(VkDeviceSize v) { return (v + kAlign - 1) / kAlign * kAlign; }
}  // namespace

UploadBufferRef upload_buffer_ref(const Buffer& buffer) noexcept {
  return {buffer.handle(), buffer.size(), (buffer.usage() & VK_BUFFER_USAGE_STORAGE_BUFFER_BIT) != 0};
}

StagedUploads::StagedUploads(Context& context, FrameRing& ring) : context_(&context), ring_(&ring) {}
StagedUploads::~StagedUploads() = default;

std::uint32_t device_scatter_min_regions(const Context& context) noexcept {
  return context.properties().deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU ? kCpuScatterMinRegions : kGpuScatterMinRegions;
}

Expected<std::unique_ptr<StagedUploads>> StagedUploads::create(Context& context, FrameRing& ring,
                                                                const StagedUploadsCreateInfo& info) {
  std::unique_ptr<StagedUploads> s(new StagedUploads(context, ring));
  s->info_ = info;
  if (info.scatter_min_regions == kDeviceScatterMinRegions) s->info_.scatter_min_regions = device_scatter_min_regions(context);
  auto scatter = UploadScatter::create(context, info.scatter_max_binding_bytes);
  if (!scatter) return Error{"StagedUploads: " + scatter.message()};
  s->scatter_ = std::make_unique<UploadScatter>(std::move(*scatter));
  if (auto st = s->grow(std::max<VkDeviceSize>(info.initial_bytes, 64 * 1024)); !st) return st.error();
  s->stats_.ring_grows = 0;
  return s;
}

Status StagedUploads::grow(VkDeviceSize at_least) {
  VkDeviceSize size = std::max<VkDeviceSize>(align_up(at_least), buffer_.valid() ? buffer_.size() * 2 : 0);
  if (info_.max_ring_bytes != 0) {
    if (align_up(at_least) > info_.max_ring_bytes)
      return Error{"StagedUploads: a " + std::to_string(align_up(at_least)) + "-byte staging ring would pass the cap of " +
                   std::to_string(info_.max_ring_bytes) + " bytes"};
    size = std::min(size, info_.max_ring_bytes);
  }
  // Storage usage: the scatter reads source words and piece tables from the ring. Larger
  // than one binding is allowed; the scatter binds windows (or falls back to copies).
  auto b = Buffer::create(*context_, {.size = size,
                                      .usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                      .memory = MemoryUsage::HostVisible,
                                      .name = "staging ring",
                                      .allow_larger_than_binding_range = true});
  if (!b) return Error{"StagedUploads: cannot allocate a " + std::to_string(size) + "-byte staging ring: " + b.message()};
  if (buffer_.valid()) {
    // Queued copies (recorded into the next frame) and frames in flight still read the old
    // block: it goes once the next frame to be recorded has finished.
    auto old = std::make_shared<Buffer>(std::move(buffer_));
    ring_->defer_until(ring_->recording_serial(), [old] { old->destroy_after_gpu_finished(); });
  }
  buffer_ = std::move(*b);
  head_ = tail_ = 0;
  used_ = 0;
  pending_bytes_ = 0;
  releases_.clear();
  ++stats_.ring_grows;
  stats_.ring_bytes = buffer_.size();
  return Ok{};
}

void StagedUploads::reclaim() {
  const std::uint64_t done = ring_->completed_serial();
  std::size_t k = 0;
  while (k < releases_.size() && releases_[k].serial <= done) {
    tail_ = releases_[k].end;
    used_ -= releases_[k].bytes;
    ++k;
  }
  releases_.erase(releases_.begin(), releases_.begin() + static_cast<std::ptrdiff_t>(k));
  if (used_ == 0) head_ = tail_ = 0;
}

Expected<VkDeviceSize> StagedUploads::allocate(VkDeviceSize size) {
  reclaim();
  const VkDeviceSize need = align_up(size);
  auto try_take = [&]() -> std::optional<VkDeviceSize> {
    const VkDeviceSize cap = buffer_.size();
    if (used_ == 0) head_ = tail_ = 0;
    if (used_ == 0 || head_ > tail_) {
      // Free: [head, cap) and [0, tail).
      if (head_ + need <= cap) return head_;
      if (need <= tail_) {  // wrap: the bytes left at the end are wasted until released
        const VkDeviceSize waste = cap - head_;
        used_ += waste;
        pending_bytes_ += waste;
        head_ = 0;
        return VkDeviceSize{0};
      }
      return std::nullopt;
    }
    // head <= tail with bytes in use: free is [head, tail).
    if (head_ + need <= tail_) return head_;
    return std::nullopt;
  };
  auto at = try_take();
  if (!at) {
    if (auto st = grow(need + pending_bytes_ + buffer_.size()); !st) return st.error();
    at = try_take();
    if (!at) return Error{"StagedUploads: no room for " + std::to_string(size) + " bytes after growing"};
  }
  head_ = *at + need;
  used_ += need;
  pending_bytes_ += need;
  return *at;
}

Expected<std::span<std::byte>> StagedUploads::reserve(const Buffer& dst, VkDeviceSize offset, VkDeviceSize size) {
  if (auto st = dst.check_range(offset, size); !st) return Error{"StagedUploads: " + st.message()};
  if (size == 0) return std::span<std::byte>{};
  auto at = allocate(size);
  if (!at) return at.error();
  const UploadBufferRef src = upload_buffer_ref(buffer_);
  // The newest group for `dst` takes the copy unless it reads another staging block or
  // already writes some of these bytes: then a new group behind a barrier keeps
  // the writes in order.
  auto it = open_group_.find(dst.handle());
  Group* g = nullptr;
  if (it != open_group_.end()) {
    Group& open = groups_[it->second];
    bool overlaps = open.src.handle != src.handle;
    if (!overlaps) {
      auto next = open.spans.lower_bound(offset);
      if (next != open.spans.end() && next->first < offset + size) overlaps = true;
      if (next != open.spans.begin() && std::prev(next)->second > offset) overlaps = true;
    }
    if (!overlaps) g = &open;
  }
  if (g == nullptr) {
    const bool after_earlier = it != open_group_.end();
    groups_.push_back(Group{src, upload_buffer_ref(dst), {}, {}, after_earlier});
    open_group_[dst.handle()] = groups_.size() - 1;
    g = &groups_.back();
  }
  // Extend the previous region when both the staging and the destination bytes follow on.
  if (!g->regions.empty()) {
    VkBufferCopy& last = g->regions.back();
    if (last.srcOffset + align_up(last.size) == *at && last.size == align_up(last.size) &&
        last.dstOffset + last.size == offset) {
      last.size += size;
      auto span_it = g->spans.find(last.dstOffset);
      if (span_it != g->spans.end()) span_it->second = last.dstOffset + last.size;
      ++stats_.writes;
      stats_.bytes += size;
      return std::span<std::byte>(static_cast<std::byte*>(buffer_.mapped()) + *at, size);
    }
  }
  g->regions.push_back(VkBufferCopy{*at, offset, size});
  g->spans[offset] = offset + size;
  ++stats_.writes;
  stats_.bytes += size;
  return std::span<std::byte>(static_cast<std::byte*>(buffer_.mapped()) + *at, size);
}

Status StagedUploads::write(const Buffer& dst, VkDeviceSize offset, const void* data, VkDeviceSize size) {
  if (size > 0 && data == nullptr) return Error{"StagedUploads: write of " + std::to_string(size) + " bytes from null"};
  auto span = reserve(dst, offset, size);
  if (!span) return span.error();
  if (size > 0) std::memcpy(span->data(), data, size);
  return Ok{};
}

Status StagedUploads::copy_from(const Buffer& src, const Buffer& dst, std::span<const VkBufferCopy> regions) {
  if (regions.empty()) return Ok{};
  VkDeviceSize bytes = 0;
  for (const VkBufferCopy& r : regions) {
    if (auto st = src.check_range(r.srcOffset, r.size); !st) return Error{"StagedUploads: " + st.message()};
    if (auto st = dst.check_range(r.dstOffset, r.size); !st) return Error{"StagedUploads: " + st.message()};
    bytes += r.size;
  }
  // A group of its own: another source than the ring's, so later ring writes to `dst`
  // start a new group behind a barrier (reserve() sees a foreign source as overlapping).
  auto it = open_group_.find(dst.handle());
  const bool after_earlier = it != open_group_.end();
  groups_.push_back(Group{upload_buffer_ref(src), upload_buffer_ref(dst), {regions.begin(), regions.end()}, {}, after_earlier});
  open_group_[dst.handle()] = groups_.size() - 1;
  stats_.writes += regions.size();
  stats_.bytes += bytes;
  return Ok{};
}

struct StagedUploads::StagedScatter {
  ScatterPlan plan;
  VkBuffer table;       // the ring block the table lies in
  VkDeviceSize offset;  // its binding offset there
};

std::optional<StagedUploads::StagedScatter> StagedUploads::stage_scatter(const Group& g) {
  if (g.regions.size() < info_.scatter_min_regions) return std::nullopt;
  auto plan = scatter_->plan(g.src, g.dst, g.regions);
  if (!plan) {
    ++stats_.scatter_fallbacks;
    return std::nullopt;
  }
  // The ring gives kAlign-aligned bytes; a device wanting coarser binding offsets gets
  // the slack to round up in.
  const VkDeviceSize align = scatter_->table_alignment();
  auto at = allocate(plan->table_bytes() + (align > kAlign ? align - kAlign : 0));
  if (!at) {  // no staging for the table: the copy still applies every region
    ++stats_.scatter_fallbacks;
    return std::nullopt;
  }
  const VkDeviceSize offset = (*at + align - 1) / align * align;
  UploadScatter::write_table(*plan, g.regions, static_cast<std::byte*>(buffer_.mapped()) + offset);
  return StagedScatter{*plan, buffer_.handle(), offset};
}

void StagedUploads::record(VkCommandBuffer cmd) {
  // What has been recorded so far: the writes a barrier before a later group waits for.
  VkPipelineStageFlags2 written_stages = 0;
  VkAccessFlags2 written_access = 0;
  for (const Group& g : groups_) {
    // Staged before the barrier: a table that finds no room turns the group into a copy.
    const std::optional<StagedScatter> scatter = stage_scatter(g);
    if (g.barrier_before) {
      // Overlapping bytes of one destination: every earlier write (copy or scatter) is done
      // and visible before this group writes (write after write).
      if (scatter)
        memory_barrier(cmd, written_stages, written_access, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
      else
        memory_barrier(cmd, written_stages, written_access, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                       VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT);
    }
    if (scatter) {
      stats_.scatter_dispatches += scatter_->record(cmd, scatter->plan, g.src, g.dst, scatter->table, scatter->offset);
      stats_.scatter_regions += g.regions.size();
      stats_.scatter_pieces += scatter->plan.pieces;
      ++stats_.scatter_groups;
      written_stages |= VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
      written_access |= VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
    } else {
      vkCmdCopyBuffer(cmd, g.src.handle, g.dst.handle, static_cast<std::uint32_t>(g.regions.size()), g.regions.data());
      stats_.copy_regions += g.regions.size();
      ++stats_.copy_groups;
      written_stages |= VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
      written_access |= VK_ACCESS_2_TRANSFER_WRITE_BIT;
    }
  }
  if (written_stages != 0)
    memory_barrier(cmd, written_stages, written_access,
                   VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_VERTEX_INPUT_BIT |
                       VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT |
                       VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                   VK_ACCESS_2_SHADER_READ_BIT | VK_ACCESS_2_SHADER_WRITE_BIT | VK_ACCESS_2_INDEX_READ_BIT |
                       VK_ACCESS_2_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT |
                       VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT);
}

void StagedUploads::submitted() {
  groups_.clear();
  open_group_.clear();
  if (pending_bytes_ > 0) {
    releases_.push_back(Release{ring_->submitted_serial(), head_, pending_bytes_});
    pending_bytes_ = 0;
  }
}

}  // namespace gauss::vk
