#pragma once
// Internal state of SplatRenderer (render/src/splat only): the GPU buffers of a frame and
// the recording of one view's passes.
#include <array>
#include <cstdint>
#include <memory>
#include <optional>

#include "gauss/engine/camera.h"
#include "gauss/render/mesh_pass.h"
#include "gauss/render/slot_buffer.h"
#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_commands.h"
#include "gauss/render/vk_image.h"
#include "gauss/render/vk_timestamps.h"
#include "splat_pipelines.h"

namespace gauss::render {

// Timestamp slots of one view (the passes of SplatPassTimings, in order).
inline constexpr std::uint32_t kViewTimestamps = 9;

struct ViewResources {
  vk::Buffer view_ubo;   // GpuView, host visible
  vk::Buffer counters;   // SPLAT_COUNTER_WORDS, host visible (stats after the frame), indirect args
  vk::Buffer ranges;     // uvec2 per tile
  vk::OffscreenTarget target;
  vk::TimestampQueries timestamps;
  bool had_mesh{false};
};

struct SplatRenderer::Impl {
  vk::Context* context{nullptr};
  SplatRendererCreateInfo info;
  SlotBuffer slots;
  MeshPass mesh;
  splat::SplatPipelines pipelines;
  vk::CommandBuffer cmd;

  // Shared by the views of a frame (used one view after the other, with barriers).
  vk::Buffer projected;   // GpuProjected per slot
  vk::Buffer tile_count;  // uint per slot
  vk::Buffer offsets;     // uint per slot / per visible splat
  std::array<vk::Buffer, 2> keys;  // ping-pong sort keys, max(capacity, max_pairs)
  std::array<vk::Buffer, 2> vals;
  vk::Buffer hist;        // 16 * blocks
  vk::Buffer tile_depth;  // float per tile
  vk::Buffer output;      // packed RGBA8 per pixel
  vk::Buffer highlight;   // sorted object ids
  std::uint32_t highlight_count{0};
  std::uint32_t display_frame{0};
  std::array<ViewResources, 2> views;

  // Records the passes of one view into `c`. Errors only for resources that fail to bind.
  Status record_view(VkCommandBuffer c, std::uint32_t v, const Camera& camera, const SplatRenderOptions& options);
  Status prepare_view(std::uint32_t v, const Camera& camera, const SplatRenderOptions& options);
  Expected<SplatFrameStats> read_stats(std::uint32_t v) const;
  Expected<std::array<SplatFrameStats, 2>> render_views(std::span<const Camera> cameras,
                                                       const SplatRenderOptions& options);
};

}  // namespace gauss::render
