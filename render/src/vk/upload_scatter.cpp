// UploadScatter: the piece table and dispatch of shaders/upload_scatter.comp (see the header).
#include "vk/upload_scatter.h"

#include <algorithm>
#include <cstring>

#include "gauss/render/vk_context.h"
#include "gauss/shaders/upload_scatter.comp.spv.h"
#include "upload_scatter_layout.h"

namespace gauss::vk {

namespace {
constexpr VkDeviceSize kWord = 4;
constexpr VkDeviceSize kPieceBytes = VkDeviceSize{gpu::UPLOAD_SCATTER_PIECE_WORDS} * kWord;
}  // namespace

VkDeviceSize ScatterPlan::table_bytes() const noexcept { return pieces * sizeof(gpu::UploadScatterPiece); }

Expected<UploadScatter> UploadScatter::create(Context& context, VkDeviceSize max_binding_bytes) {
  UploadScatter s;
  auto pipe = ComputePipeline::create(context, {.name = "upload scatter",
                                                .shader = spirv(gauss_spv_upload_scatter_comp),
                                                .bindings = {{gpu::UPLOAD_SCATTER_BINDING_SRC, DescriptorKind::StorageBuffer},
                                                             {gpu::UPLOAD_SCATTER_BINDING_DST, DescriptorKind::StorageBuffer},
                                                             {gpu::UPLOAD_SCATTER_BINDING_PIECES, DescriptorKind::StorageBuffer}},
                                                .push_constant_size = sizeof(gpu::UploadScatterPush)});
  if (!pipe) return pipe.error();
  s.pipeline_ = std::move(*pipe);
  const VkPhysicalDeviceLimits& limits = context.limits();
  const VkDeviceSize device_range = limits.maxStorageBufferRange;
  s.max_binding_ = max_binding_bytes == 0 ? device_range : std::min(max_binding_bytes, device_range);
  // Word offsets are uints: a window of more than 16 GiB could not be addressed (no device has one).
  s.max_binding_ = std::min<VkDeviceSize>(s.max_binding_, VkDeviceSize{1} << 34);
  s.offset_alignment_ = std::max<VkDeviceSize>(limits.minStorageBufferOffsetAlignment, kWord);
  s.max_groups_x_ = limits.maxComputeWorkGroupCount[0];
  return s;
}

std::optional<ScatterPlan> UploadScatter::plan(const UploadBufferRef& src, const UploadBufferRef& dst,
                                               std::span<const VkBufferCopy> regions) const {
  if (regions.empty() || !src.storage || !dst.storage || src.handle == dst.handle) return std::nullopt;
  VkDeviceSize src_lo = src.size, src_hi = 0, dst_lo = dst.size, dst_hi = 0;
  std::uint64_t pieces = 0;
  for (const VkBufferCopy& r : regions) {
    if (r.srcOffset % kWord != 0 || r.dstOffset % kWord != 0 || r.size % kWord != 0 || r.size == 0)
      return std::nullopt;
    src_lo = std::min(src_lo, r.srcOffset);
    src_hi = std::max(src_hi, r.srcOffset + r.size);
    dst_lo = std::min(dst_lo, r.dstOffset);
    dst_hi = std::max(dst_hi, r.dstOffset + r.size);
    pieces += (r.size + kPieceBytes - 1) / kPieceBytes;
  }
  ScatterPlan p;
  p.src_base = src_lo / offset_alignment_ * offset_alignment_;
  p.dst_base = dst_lo / offset_alignment_ * offset_alignment_;
  p.src_range = src_hi - p.src_base;
  p.dst_range = dst_hi - p.dst_base;
  p.pieces = pieces;
  if (p.src_range > max_binding_ || p.dst_range > max_binding_ || p.table_bytes() > max_binding_) return std::nullopt;
  return p;
}

void UploadScatter::write_table(const ScatterPlan& plan, std::span<const VkBufferCopy> regions, std::byte* table) {
  std::uint64_t k = 0;
  for (const VkBufferCopy& r : regions) {
    for (VkDeviceSize at = 0; at < r.size; at += kPieceBytes) {
      const gpu::UploadScatterPiece piece{static_cast<std::uint32_t>((r.srcOffset + at - plan.src_base) / kWord),
                                          static_cast<std::uint32_t>((r.dstOffset + at - plan.dst_base) / kWord),
                                          static_cast<std::uint32_t>(std::min(kPieceBytes, r.size - at) / kWord)};
      // memcpy: the ring gives 16-byte aligned bytes, but say nothing of object lifetimes.
      std::memcpy(table + k * sizeof(piece), &piece, sizeof(piece));
      ++k;
    }
  }
}

std::uint32_t UploadScatter::record(VkCommandBuffer cmd, const ScatterPlan& plan, const UploadBufferRef& src,
                           const UploadBufferRef& dst, VkBuffer table, VkDeviceSize offset) const {
  // Descriptors written here, not through PipelineBase::bind: a group keeps handles (the
  // Buffer objects may have moved since the write was queued), and plan() has checked
  // every range and offset bind() would.
  const VkDescriptorBufferInfo infos[3] = {{src.handle, plan.src_base, plan.src_range},
                                           {dst.handle, plan.dst_base, plan.dst_range},
                                           {table, offset, plan.table_bytes()}};
  const std::uint32_t bindings[3] = {gpu::UPLOAD_SCATTER_BINDING_SRC, gpu::UPLOAD_SCATTER_BINDING_DST,
                                     gpu::UPLOAD_SCATTER_BINDING_PIECES};
  VkWriteDescriptorSet writes[3]{};
  for (int i = 0; i < 3; ++i) {
    writes[i].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    writes[i].dstBinding = bindings[i];
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &infos[i];
  }
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_.handle());
  vkCmdPushDescriptorSetKHR(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_.layout(), 0, 3, writes);
  // More pieces than one dispatch's workgroups reach: several dispatches, each its slice.
  const std::uint64_t per_dispatch = std::uint64_t{max_groups_x_} * gpu::UPLOAD_SCATTER_PIECES_PER_GROUP;
  std::uint32_t dispatches = 0;
  for (std::uint64_t first = 0; first < plan.pieces; first += per_dispatch) {
    const std::uint64_t end = std::min(plan.pieces, first + per_dispatch);
    const gpu::UploadScatterPush push{static_cast<std::uint32_t>(first), static_cast<std::uint32_t>(end)};
    pipeline_.push_constants(cmd, push);
    const std::uint64_t groups = (end - first + gpu::UPLOAD_SCATTER_PIECES_PER_GROUP - 1) / gpu::UPLOAD_SCATTER_PIECES_PER_GROUP;
    vkCmdDispatch(cmd, static_cast<std::uint32_t>(groups), 1, 1);
    ++dispatches;
  }
  return dispatches;
}

}  // namespace gauss::vk
