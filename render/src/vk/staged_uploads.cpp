// StagedUploads: the staging ring and the copy groups it feeds (see the header).
#include "gauss/render/vk_staged_uploads.h"

#include <algorithm>
#include <cstring>
#include <iterator>
#include <optional>
#include <string>

#include "gauss/render/vk_commands.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_frame_ring.h"

namespace gauss::vk {

namespace {
constexpr VkDeviceSize kAlign = 16;
VkDeviceSize align_up(VkDeviceSize v) { return (v + kAlign - 1) / kAlign * kAlign; }
}  // namespace

Expected<std::unique_ptr<StagedUploads>> StagedUploads::create(Context& context, FrameRing& ring,
                                                                VkDeviceSize initial_bytes) {
  std::unique_ptr<StagedUploads> s(new StagedUploads(context, ring));
  if (auto st = s->grow(std::max<VkDeviceSize>(initial_bytes, 64 * 1024)); !st) return st.error();
  s->stats_.ring_grows = 0;
  return s;
}

Status StagedUploads::grow(VkDeviceSize at_least) {
  const VkDeviceSize size = std::max<VkDeviceSize>(align_up(at_least), buffer_.valid() ? buffer_.size() * 2 : 0);
  auto b = Buffer::create(*context_, {.size = size,
                                      .usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                      .memory = MemoryUsage::HostVisible,
                                      .name = "staging ring"});
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
  const VkBuffer src = buffer_.handle();
  // The newest group for `dst` takes the copy unless it reads another staging block or
  // already writes some of these bytes: then a new group behind a transfer barrier keeps
  // the writes in order.
  auto it = open_group_.find(dst.handle());
  Group* g = nullptr;
  if (it != open_group_.end()) {
    Group& open = groups_[it->second];
    bool overlaps = open.src != src;
    if (!overlaps) {
      auto next = open.spans.lower_bound(offset);
      if (next != open.spans.end() && next->first < offset + size) overlaps = true;
      if (next != open.spans.begin() && std::prev(next)->second > offset) overlaps = true;
    }
    if (!overlaps) g = &open;
  }
  if (g == nullptr) {
    const bool after_earlier = it != open_group_.end();
    groups_.push_back(Group{src, dst.handle(), {}, {}, after_earlier});
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
  groups_.push_back(Group{src.handle(), dst.handle(), {regions.begin(), regions.end()}, {}, after_earlier});
  open_group_[dst.handle()] = groups_.size() - 1;
  stats_.writes += regions.size();
  stats_.bytes += bytes;
  return Ok{};
}

void StagedUploads::record(VkCommandBuffer cmd) {
  for (const Group& g : groups_) {
    if (g.barrier_before)
      memory_barrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    vkCmdCopyBuffer(cmd, g.src, g.dst, static_cast<std::uint32_t>(g.regions.size()), g.regions.data());
    stats_.copy_regions += g.regions.size();
    ++stats_.copy_groups;
  }
  if (!groups_.empty())
    memory_barrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
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
