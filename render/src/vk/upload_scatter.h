#pragma once
// gauss::vk::UploadScatter: applies one StagedUploads copy group of many regions as one
// compute dispatch (shaders/upload_scatter.comp) instead of one vkCmdCopyBuffer.
//
// Why: the GPU charges per VkBufferCopy region, not per byte. Progressive publication
// writes thousands of scattered slot runs a frame (~2 MB in all), one region per run and
// buffer; on an H100 that upload pass took p95 3.9 ms, p99 4.6 ms. A piece table of
// (source word, destination word, words) in the staging ring and one dispatch copy the
// same bytes with consecutive invocations on consecutive words.
//
// When: plan() refuses (the group keeps vkCmdCopyBuffer) a region whose offsets or size are
// not multiples of 4 bytes, a source or destination without STORAGE_BUFFER usage, source
// and destination being one buffer, or a group whose source or destination bytes span
// more than one storage binding may cover (maxStorageBufferRange, or less for tests): the
// bindings are windows around the group's bytes, not whole buffers, so a buffer larger
// than the range still scatters when the group's bytes fit one window.
#include <cstdint>
#include <optional>
#include <span>

#include <volk.h>

#include "gauss/engine/result.h"
#include "gauss/render/vk_pipeline.h"
#include "gauss/render/vk_staged_uploads.h"

namespace gauss::vk {

class Context;

// What record() binds: a window of each buffer, and how many pieces the table has.
struct ScatterPlan {
  VkDeviceSize src_base{0}, src_range{0};
  VkDeviceSize dst_base{0}, dst_range{0};
  std::uint64_t pieces{0};
  VkDeviceSize table_bytes() const noexcept;
};

class UploadScatter {
 public:
  // `max_binding_bytes`: most bytes one binding may cover; 0 = maxStorageBufferRange.
  // Errors: pipeline creation.
  static Expected<UploadScatter> create(Context& context, VkDeviceSize max_binding_bytes);

  // Alignment the piece table's offset in its buffer needs.
  VkDeviceSize table_alignment() const noexcept { return offset_alignment_; }
  // The bindings for `regions` (src -> dst), or nothing when the scatter cannot apply them
  // (see the header comment).
  std::optional<ScatterPlan> plan(const UploadBufferRef& src, const UploadBufferRef& dst,
                                  std::span<const VkBufferCopy> regions) const;
  // Writes plan.pieces pieces for `regions` into `table` (plan.table_bytes() bytes).
  static void write_table(const ScatterPlan& plan, std::span<const VkBufferCopy> regions, std::byte* table);
  // Binds the pipeline and records the dispatches; the table lies at table[offset, +
  // plan.table_bytes()) (offset a multiple of table_alignment()). Leaves the compute
  // pipeline, descriptors and push constants bound. Returns the dispatches recorded.
  std::uint32_t record(VkCommandBuffer cmd, const ScatterPlan& plan, const UploadBufferRef& src, const UploadBufferRef& dst,
              VkBuffer table, VkDeviceSize offset) const;

 private:
  ComputePipeline pipeline_;
  VkDeviceSize max_binding_{0};
  VkDeviceSize offset_alignment_{4};
  std::uint32_t max_groups_x_{65535};
};

}  // namespace gauss::vk
