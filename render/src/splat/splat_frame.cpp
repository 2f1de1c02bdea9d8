// Recording of one view's passes (see splat_renderer.h for the sequence) and the
// per-frame statistics read back after the frame has finished.
#include <algorithm>
#include <array>
#include <bit>
#include <span>
#include <initializer_list>
#include <optional>
#include <utility>

#include "gauss/render/vk_check.h"
#include "gauss/render/vk_context.h"
#include "splat_frame.h"
#include "splat_layout.h"

namespace gauss::render {

namespace {

std::uint32_t groups(std::uint64_t items, std::uint32_t per_group) {
  return static_cast<std::uint32_t>((items + per_group - 1) / per_group);
}

glm::vec4 row_of(const glm::dmat4& m, int r) { return glm::vec4(m[0][r], m[1][r], m[2][r], m[3][r]); }

}  // namespace

Status SplatRenderer::Impl::prepare_view(FrameSlot& f, std::uint32_t v, const Camera& camera,
                                         const SplatRenderOptions& options) {
  ViewTarget& vt = targets[v];
  if (!vt.target.color().valid() || vt.target.width() != camera.width || vt.target.height() != camera.height) {
    // A new size replaces the image; frames in flight may still read the old one.
    auto t = vk::OffscreenTarget::create(*context, camera.width, camera.height,
                                         v == 0 ? "splat view 0" : "splat view 1");
    if (!t) return t.error();
    if (vt.target.color().valid()) {
      auto old = std::make_shared<vk::OffscreenTarget>(std::move(vt.target));
      ring->defer([old]() mutable { old.reset(); });
    }
    vt.target = std::move(*t);
    ++targets_generation;  // recorded passes bind the old target's images
  }
  gpu::GpuView g{};
  const glm::dmat4& m = camera.world_to_camera;
  g.w2c_row0 = row_of(m, 0);
  g.w2c_row1 = row_of(m, 1);
  g.w2c_row2 = row_of(m, 2);
  const glm::dmat3 rot(m);
  const glm::dvec3 centre = -glm::transpose(rot) * glm::dvec3(m[3]);
  g.camera_centre = glm::vec4(glm::vec3(centre), 0.0f);
  g.intrinsics = glm::vec4(camera.fx, camera.fy, camera.cx, camera.cy);
  g.limits = glm::vec4(kFrustumClamp * camera.width / (2.0 * camera.fx), kFrustumClamp * camera.height / (2.0 * camera.fy),
                       options.mesh_margin, 0.0);
  g.clear_colour = glm::vec4(options.clear_colour, 1.0f);
  g.size = glm::uvec4(camera.width, camera.height, render::tile_count(camera.width), render::tile_count(camera.height));
  g.frame = glm::uvec4(0u, display_frame, highlight_count, 0u);  // the high-water mark travels as a push constant
  return f.views[v].view_ubo.upload(&g, sizeof(g));
}

Status SplatRenderer::Impl::record_views(VkCommandBuffer c, FrameSlot& f, std::span<const ViewWork> views,
                                         const SplatRenderOptions& options) {
  // The first view's timestamps bracket the passes (of both views, when together).
  FrameViewResources& lead = f.views[views[0].v];
  const bool with_mesh = mesh.has_mesh();
  lead.timestamps.write(c, 0);
  // ---- Mesh pass (its push constants hold the camera: recorded every frame) ----
  for (const ViewWork& w : views) {
    ViewTarget& vt = targets[w.v];
    if (with_mesh) mesh.record(c, vt.target, *w.camera, options.clear_colour);
    vt.target.color().transition(c, VK_IMAGE_LAYOUT_GENERAL);
    vt.target.depth().transition(c, VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL);
    vt.had_mesh = with_mesh;
  }

  // ---- The compute passes: replayed while nothing they record has changed ----
  lead.replayed = false;
  if (!reuse_passes) {
    if (auto st = record_passes(c, f, views, options); !st) return st;
  } else {
    const Camera& camera = *views[0].camera;  // views together have one size
    const ViewPassesKey key{.width = camera.width,
                            .height = camera.height,
                            .high_water = slots.high_water(),
                            .mesh = with_mesh,
                            .tint = tint_active(),
                            .exact_culling = options.exact_culling,
                            .targets_generation = targets_generation,
                            .together = views.size() > 1};
    lead.replayed = lead.passes_key == key;
    if (!lead.replayed) {
      // This frame slot's last frame has finished (FrameRing::begin waited for it), so
      // its secondary is no longer pending.
      lead.passes_key.reset();
      GAUSS_VK_TRY(vkResetCommandBuffer(lead.passes, 0));
      VkCommandBufferInheritanceInfo inherit{};
      inherit.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_INHERITANCE_INFO;
      VkCommandBufferBeginInfo bi{};
      bi.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
      bi.pInheritanceInfo = &inherit;
      GAUSS_VK_TRY(vkBeginCommandBuffer(lead.passes, &bi));
      if (auto st = record_passes(lead.passes, f, views, options); !st) return st;
      GAUSS_VK_TRY(vkEndCommandBuffer(lead.passes));
      lead.passes_key = key;
    }
    vkCmdExecuteCommands(c, 1, &lead.passes);
  }

  // ---- The packed pixels into the targets' colour images ----
  for (const ViewWork& w : views) {
    vk::Image& colour = targets[w.v].target.color();
    colour.transition(c, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    VkBufferImageCopy region{};
    region.bufferRowLength = w.camera->width;
    region.bufferImageHeight = w.camera->height;
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {w.camera->width, w.camera->height, 1};
    vkCmdCopyBufferToImage(c, w.scratch->output.handle(), colour.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1,
                           &region);
  }
  // The next view reuses the output buffer: its blend writes wait for this copy's reads.
  vk::memory_barrier(c, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT,
                     VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_WRITE_BIT);
  lead.timestamps.write(c, 8);
  // A view recorded with the lead: its passes' time is in the lead's (read_stats reports
  // its spans as 0); its timestamps are written so that its query pool can be read.
  for (const ViewWork& w : views.subspan(1)) {
    f.views[w.v].replayed = lead.replayed;
    for (std::uint32_t i = 0; i <= 8; ++i) f.views[w.v].timestamps.write(c, i);
  }
  return Ok{};
}

Status SplatRenderer::Impl::record_passes(VkCommandBuffer c, FrameSlot& f, std::span<const ViewWork> views,
                                          const SplatRenderOptions& options) {
  // Every step below records its dispatch for each view, then one barrier: together, the
  // views' dispatches of a step may overlap on the GPU (they touch disjoint scratch).
  FrameViewResources& lead = f.views[views[0].v];
  const Camera& camera = *views[0].camera;  // views together have one size
  const bool with_mesh = mesh.has_mesh();
  const bool tint = tint_active();
  const std::uint32_t tiles_x = render::tile_count(camera.width), tiles_y = render::tile_count(camera.height);
  const std::uint32_t tiles = tiles_x * tiles_y;
  const std::uint32_t hwm = slots.high_water();
  auto ts = [&](std::uint32_t i) { lead.timestamps.write(c, i); };
  auto push = [&](const vk::ComputePipeline& p, std::uint32_t item_count, std::uint32_t count_index,
                  std::uint32_t shift, std::uint32_t first_slot = 0) {
    const gpu::GpuSplatPush pc{item_count, count_index, shift, info.max_pairs, first_slot};
    p.push_constants(c, pc);
  };
  // Slot chunks below the high-water mark: [first, first + count) of chunk k.
  struct ChunkRun {
    std::uint32_t chunk, first, count;
  };
  std::array<ChunkRun, gpu::SPLAT_MAX_SLOT_CHUNKS> run_array{};
  std::uint32_t run_count = 0;
  for (std::uint32_t k = 0; k < slots.chunk_count() && std::uint64_t{k} * slots.chunk_slots() < hwm; ++k) {
    const std::uint32_t first = k * slots.chunk_slots();
    run_array[run_count++] = {k, first, std::min(hwm - first, slots.chunk_slots())};
  }
  const std::span<const ChunkRun> runs(run_array.data(), run_count);
  // Emit and blend read projected splats of any chunk: every chunk binding is given, the
  // ones past the last chunk repeat chunk 0 (never read, splat_projected.glsl).
  auto projected_chunk = [](const ViewScratch& s, std::uint32_t k) -> const vk::Buffer* {
    return &s.projected[k < s.projected.size() ? k : 0];
  };
  auto indirect = [&](const vk::Buffer& counters, std::uint32_t word) {
    vkCmdDispatchIndirect(c, counters.handle(), VkDeviceSize{word} * 4);
  };
  // Records `step` for every view (an error stops at once).
  auto each_view = [&](auto&& step) -> Status {
    for (const ViewWork& w : views)
      if (auto st = step(f.views[w.v], *w.scratch, targets[w.v]); !st) return st;
    return Ok{};
  };

  // ---- Per-tile max mesh depth (after the mesh pass, record_views) ----
  if (with_mesh) {
    const auto& p = pipelines.tile_depth();
    if (auto done = each_view([&](FrameViewResources& view, ViewScratch& s, ViewTarget& vt) -> Status {
          if (auto st = p.bind(c, {{gpu::SPLAT_BINDING_VIEW, &view.view_ubo},
                                   {gpu::SPLAT_BINDING_MESH_DEPTH, &vt.target.depth()},
                                   {gpu::SPLAT_BINDING_TILE_DEPTH, &s.tile_depth}});
              !st)
            return st;
          push(p, 0, 0, 0);
          vkCmdDispatch(c, tiles_x, tiles_y, 1);
          return Ok{};
        });
        !done)
      return done;
    vk::compute_to_compute_barrier(c);
  }
  ts(1);

  // ---- Preprocess ----
  auto pre = pipelines.preprocess({.sh_degree = static_cast<std::uint32_t>(slots.sh_degree()),
                                   .sh_stride = slots.sh_stride(),
                                   .tint = tint,
                                   .mesh = with_mesh,
                                   .exact_cull = options.exact_culling});
  if (!pre) return pre.error();
  // One dispatch per chunk (they write disjoint slots: no barrier between them).
  if (auto done = each_view([&](FrameViewResources& view, ViewScratch& s, ViewTarget&) -> Status {
        for (const ChunkRun& r : runs) {
          if (auto st = (*pre)->bind(c, {{gpu::SPLAT_BINDING_VIEW, &view.view_ubo},
                                         {gpu::SPLAT_BINDING_CORE, &slots.core_buffer(r.chunk)},
                                         {gpu::SPLAT_BINDING_SH, &slots.sh_buffer(r.chunk)},
                                         {gpu::SPLAT_BINDING_SH_HIGH, &slots.sh_high_buffer(r.chunk)},
                                         {gpu::SPLAT_BINDING_EDIT, &slots.edit_buffer()},
                                         {gpu::SPLAT_BINDING_HIGHLIGHT, &highlight},
                                         {gpu::SPLAT_BINDING_PROJECTED, &s.projected[r.chunk]},
                                         {gpu::SPLAT_BINDING_TILE_COUNT, &s.tile_count},
                                         {gpu::SPLAT_BINDING_TILE_DEPTH, &s.tile_depth}});
              !st)
            return st;
          push(**pre, r.count, 0, 0, r.first);
          vkCmdDispatch(c, groups(r.count, gpu::SPLAT_WORKGROUP), 1, 1);
        }
        return Ok{};
      });
      !done)
    return done;
  if (hwm > 0) vk::compute_to_compute_barrier(c);
  ts(2);

  // ---- Visible list in slot order ----
  auto scan_res = [](FrameViewResources& view, ViewScratch& s) {
    return std::array<vk::Resource, 5>{vk::Resource{gpu::SPLAT_BINDING_TILE_COUNT, &s.tile_count},
                                       vk::Resource{gpu::SPLAT_BINDING_VALS_IN, &s.vals[0]},
                                       vk::Resource{gpu::SPLAT_BINDING_OFFSETS, &s.offsets},
                                       vk::Resource{gpu::SPLAT_BINDING_HIST, &s.hist},
                                       vk::Resource{gpu::SPLAT_BINDING_COUNTERS, &view.counters}};
  };
  // CPU shapes: one dispatch. GPU shapes: block sums, their scan (the spine, which also
  // writes the totals and arguments), then every block rescanned: no workgroup waits on
  // another (splat_scan_gpu.comp).
  const bool gpu_shapes = pipelines.shapes() == SplatPassShapes::Gpu;
  auto scan_step = [&](const vk::ComputePipeline& p, std::uint32_t item_count, std::uint32_t groups_direct) -> Status {
    if (auto done = each_view([&](FrameViewResources& view, ViewScratch& s, ViewTarget&) -> Status {
          const auto res = scan_res(view, s);
          if (auto st = p.bind(c, res); !st) return st;
          push(p, item_count, 0, 0);
          // Past SPLAT_DISPATCH_ROW groups the dispatch wraps into y, as the indirect ones
          // do (the shader's linear_group_id; groups past the last block return at once).
          vkCmdDispatch(c, std::min(groups_direct, gpu::SPLAT_DISPATCH_ROW),
                        groups(groups_direct, gpu::SPLAT_DISPATCH_ROW), 1);
          return Ok{};
        });
        !done)
      return done;
    vk::compute_to_compute_barrier(c);
    return Ok{};
  };
  const std::uint32_t visible_blocks = groups(hwm, gpu::SORT_BLOCK_GPU);
  if (gpu_shapes && visible_blocks > 0)
    if (auto st = scan_step(pipelines.scan_visible_reduce(), hwm, visible_blocks); !st) return st;
  if (auto st = scan_step(pipelines.scan_visible(), hwm, 1); !st) return st;
  if (gpu_shapes && visible_blocks > 0)
    if (auto st = scan_step(pipelines.scan_visible_down(), hwm, visible_blocks); !st) return st;
  if (auto done = each_view([&](FrameViewResources&, ViewScratch& s, ViewTarget&) -> Status {
        for (const ChunkRun& r : runs) {
          if (auto st = pipelines.compact().bind(c, {{gpu::SPLAT_BINDING_PROJECTED, &s.projected[r.chunk]},
                                                     {gpu::SPLAT_BINDING_TILE_COUNT, &s.tile_count},
                                                     {gpu::SPLAT_BINDING_OFFSETS, &s.offsets},
                                                     {gpu::SPLAT_BINDING_KEYS_OUT, &s.keys[0]},
                                                     {gpu::SPLAT_BINDING_VALS_OUT, &s.vals[0]}});
              !st)
            return st;
          push(pipelines.compact(), r.count, 0, 0, r.first);
          vkCmdDispatch(c, groups(r.count, gpu::SPLAT_WORKGROUP), 1, 1);
        }
        return Ok{};
      });
      !done)
    return done;
  if (hwm > 0) vk::compute_to_compute_barrier(c);
  ts(3);

  // One stable radix pass: keys/vals[src] -> keys/vals[1 - src] on digit `shift`.
  // fused_offsets (GPU shapes, few blocks): no offsets pass; the scatter sums the counts.
  auto radix_pass = [&](std::uint32_t src, std::uint32_t shift, std::uint32_t count_index,
                        std::uint32_t blocks_args, std::uint32_t count_args, std::uint32_t hist_args,
                        bool fused_offsets) -> Status {
    const std::uint32_t dst = 1 - src;
    if (auto done = each_view([&](FrameViewResources& view, ViewScratch& s, ViewTarget&) -> Status {
          if (auto st = pipelines.radix_count().bind(c, {{gpu::SPLAT_BINDING_KEYS_IN, &s.keys[src]},
                                                         {gpu::SPLAT_BINDING_HIST, &s.hist},
                                                         {gpu::SPLAT_BINDING_COUNTERS, &view.counters}});
              !st)
            return st;
          push(pipelines.radix_count(), 0, count_index, shift);
          indirect(view.counters, count_args);
          return Ok{};
        });
        !done)
      return done;
    vk::compute_to_compute_barrier(c);
    if (!fused_offsets) {
      if (auto done = each_view([&](FrameViewResources& view, ViewScratch& s, ViewTarget&) -> Status {
            // GPU shapes: one workgroup per digit row, which binds the histogram and
            // counters only.
            const std::array<vk::Resource, 2> offsets_res = {vk::Resource{gpu::SPLAT_BINDING_HIST, &s.hist},
                                                             vk::Resource{gpu::SPLAT_BINDING_COUNTERS, &view.counters}};
            const auto all_res = scan_res(view, s);
            const Status bound =
                gpu_shapes ? pipelines.scan_hist().bind(c, offsets_res) : pipelines.scan_hist().bind(c, all_res);
            if (!bound) return bound;
            push(pipelines.scan_hist(), 0, count_index, shift);
            indirect(view.counters, hist_args);
            return Ok{};
          });
          !done)
        return done;
      vk::compute_to_compute_barrier(c);
    }
    const vk::ComputePipeline& scatter = fused_offsets ? pipelines.radix_scatter_fused() : pipelines.radix_scatter();
    if (auto done = each_view([&](FrameViewResources& view, ViewScratch& s, ViewTarget&) -> Status {
          if (auto st = scatter.bind(c, {{gpu::SPLAT_BINDING_KEYS_IN, &s.keys[src]},
                                         {gpu::SPLAT_BINDING_VALS_IN, &s.vals[src]},
                                         {gpu::SPLAT_BINDING_KEYS_OUT, &s.keys[dst]},
                                         {gpu::SPLAT_BINDING_VALS_OUT, &s.vals[dst]},
                                         {gpu::SPLAT_BINDING_HIST, &s.hist},
                                         {gpu::SPLAT_BINDING_COUNTERS, &view.counters}});
              !st)
            return st;
          push(scatter, 0, count_index, shift);
          indirect(view.counters, blocks_args);
          return Ok{};
        });
        !done)
      return done;
    vk::compute_to_compute_barrier(c);
    return Ok{};
  };

  // ---- Depth sort: all 32 bits of the float key (8 or 4 passes: the result is back in [0]) ----
  // The visible splats are at most the high-water mark: with few enough blocks the GPU
  // scatters sum their block counts themselves (one dispatch and barrier less per pass).
  const std::uint32_t digit_bits = pipelines.radix_bits();
  const bool depth_fused = gpu_shapes && visible_blocks <= gpu::SORT_FUSED_OFFSETS_MAX_BLOCKS;
  std::uint32_t src = 0;
  for (std::uint32_t shift = 0; shift < 32; shift += digit_bits) {
    if (auto st = radix_pass(src, shift, gpu::SPLAT_COUNTER_VISIBLE, gpu::SPLAT_ARGS_VISIBLE_BLOCKS,
                             gpu::SPLAT_ARGS_VISIBLE_COUNT, gpu::SPLAT_ARGS_VISIBLE_HIST, depth_fused);
        !st)
      return st;
    src = 1 - src;
  }
  ts(4);

  // ---- Pair offsets in depth order, then emit (tile, slot) into [1 - src] ----
  // GPU shapes: the visible radix-block arguments size the reduce and down steps (the scan
  // block is the radix block, SORT_BLOCK_GPU).
  auto pair_scan_step = [&](const vk::ComputePipeline& p, bool by_blocks) -> Status {
    if (auto done = each_view([&](FrameViewResources& view, ViewScratch& s, ViewTarget&) -> Status {
          if (auto st = p.bind(c, {{gpu::SPLAT_BINDING_TILE_COUNT, &s.tile_count},
                                   {gpu::SPLAT_BINDING_VALS_IN, &s.vals[src]},
                                   {gpu::SPLAT_BINDING_OFFSETS, &s.offsets},
                                   {gpu::SPLAT_BINDING_HIST, &s.hist},
                                   {gpu::SPLAT_BINDING_COUNTERS, &view.counters}});
              !st)
            return st;
          push(p, 0, 0, 0);
          if (by_blocks) indirect(view.counters, gpu::SPLAT_ARGS_VISIBLE_BLOCKS);
          else vkCmdDispatch(c, 1, 1, 1);
          return Ok{};
        });
        !done)
      return done;
    vk::compute_to_compute_barrier(c);
    return Ok{};
  };
  if (gpu_shapes)
    if (auto st = pair_scan_step(pipelines.scan_pairs_reduce(), true); !st) return st;
  if (auto st = pair_scan_step(pipelines.scan_pairs(), false); !st) return st;
  if (gpu_shapes)
    if (auto st = pair_scan_step(pipelines.scan_pairs_down(), true); !st) return st;
  auto emit = pipelines.emit(with_mesh, options.exact_culling);
  if (!emit) return emit.error();
  if (auto done = each_view([&](FrameViewResources& view, ViewScratch& s, ViewTarget&) -> Status {
        if (auto st = (*emit)->bind(c, {{gpu::SPLAT_BINDING_VIEW, &view.view_ubo},
                                        {gpu::SPLAT_BINDING_PROJECTED, projected_chunk(s, 0)},
                                        {gpu::SPLAT_BINDING_PROJECTED_1, projected_chunk(s, 1)},
                                        {gpu::SPLAT_BINDING_PROJECTED_2, projected_chunk(s, 2)},
                                        {gpu::SPLAT_BINDING_PROJECTED_3, projected_chunk(s, 3)},
                                        {gpu::SPLAT_BINDING_TILE_COUNT, &s.tile_count},
                                        {gpu::SPLAT_BINDING_OFFSETS, &s.offsets},
                                        {gpu::SPLAT_BINDING_VALS_IN, &s.vals[src]},
                                        {gpu::SPLAT_BINDING_KEYS_OUT, &s.keys[1 - src]},
                                        {gpu::SPLAT_BINDING_VALS_OUT, &s.vals[1 - src]},
                                        {gpu::SPLAT_BINDING_COUNTERS, &view.counters},
                                        {gpu::SPLAT_BINDING_TILE_DEPTH, &s.tile_depth}});
            !st)
          return st;
        push(**emit, 0, 0, 0);
        indirect(view.counters, gpu::SPLAT_ARGS_VISIBLE_ITEMS);
        return Ok{};
      });
      !done)
    return done;
  vk::compute_to_compute_barrier(c);
  src = 1 - src;
  ts(5);

  // ---- Tile sort: only the bits of the tile ids, 0 .. tiles - 1 ----
  const std::uint32_t tile_bits = static_cast<std::uint32_t>(std::bit_width(tiles - 1));
  for (std::uint32_t shift = 0; shift < tile_bits; shift += digit_bits) {
    if (auto st = radix_pass(src, shift, gpu::SPLAT_COUNTER_PAIRS, gpu::SPLAT_ARGS_PAIR_BLOCKS,
                             gpu::SPLAT_ARGS_PAIR_COUNT, gpu::SPLAT_ARGS_PAIR_HIST, false);
        !st)
      return st;
    src = 1 - src;
  }
  ts(6);

  // ---- Tile ranges ----
  if (auto done = each_view([&](FrameViewResources& view, ViewScratch& s, ViewTarget& vt) -> Status {
        if (auto st = pipelines.ranges().bind(c, {{gpu::SPLAT_BINDING_VIEW, &view.view_ubo},
                                                  {gpu::SPLAT_BINDING_KEYS_IN, &s.keys[src]},
                                                  {gpu::SPLAT_BINDING_RANGES, &vt.ranges},
                                                  {gpu::SPLAT_BINDING_COUNTERS, &view.counters}});
            !st)
          return st;
        push(pipelines.ranges(), 0, 0, 0);
        indirect(view.counters, gpu::SPLAT_ARGS_PAIR_ITEMS);
        return Ok{};
      });
      !done)
    return done;
  vk::compute_to_compute_barrier(c);
  ts(7);

  // ---- Blend; record_views then copies the packed pixels into the targets' images ----
  auto blend = pipelines.blend(with_mesh);
  if (!blend) return blend.error();
  if (auto done = each_view([&](FrameViewResources& view, ViewScratch& s, ViewTarget& vt) -> Status {
        if (auto st = (*blend)->bind(c, {{gpu::SPLAT_BINDING_VIEW, &view.view_ubo},
                                         {gpu::SPLAT_BINDING_PROJECTED, projected_chunk(s, 0)},
                                         {gpu::SPLAT_BINDING_PROJECTED_1, projected_chunk(s, 1)},
                                         {gpu::SPLAT_BINDING_PROJECTED_2, projected_chunk(s, 2)},
                                         {gpu::SPLAT_BINDING_PROJECTED_3, projected_chunk(s, 3)},
                                         {gpu::SPLAT_BINDING_VALS_IN, &s.vals[src]},
                                         {gpu::SPLAT_BINDING_RANGES, &vt.ranges},
                                         {gpu::SPLAT_BINDING_OUTPUT, &s.output},
                                         {gpu::SPLAT_BINDING_MESH_COLOUR, &vt.target.color()},
                                         {gpu::SPLAT_BINDING_MESH_DEPTH, &vt.target.depth()}});
            !st)
          return st;
        push(**blend, 0, 0, 0);
        vkCmdDispatch(c, tiles_x, tiles_y, 1);
        return Ok{};
      });
      !done)
    return done;
  // The copies into the views' images (record_views) read what the blend wrote.
  vk::memory_barrier(c, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
  return Ok{};
}

Expected<SplatFrameStats> SplatRenderer::Impl::read_stats(const FrameSlot& f, std::uint32_t v) const {
  const FrameViewResources& view = f.views[v];
  std::uint32_t words[gpu::SPLAT_COUNTER_WORDS] = {};
  if (auto st = view.counters.download(words, sizeof(words)); !st) return st.error();
  SplatFrameStats s;
  s.high_water = f.high_water;
  s.visible = words[gpu::SPLAT_COUNTER_VISIBLE];
  s.pairs = words[gpu::SPLAT_COUNTER_PAIRS];
  s.pairs_needed = words[gpu::SPLAT_COUNTER_PAIRS_NEEDED];
  s.pair_overflow = s.pairs_needed > f.max_pairs;
  s.passes_replayed = view.replayed;
  s.views_together = f.together;
  auto ticks = view.timestamps.read_ticks();
  if (!ticks) return ticks.error();
  const double ns = context->timestamp_period_ns();
  auto ms = [&](std::uint32_t a, std::uint32_t b) {
    const auto& t = *ticks;
    return t[b] >= t[a] ? double(t[b] - t[a]) * ns * 1e-6 : 0.0;
  };
  s.gpu.mesh_ms = ms(0, 1);
  s.gpu.preprocess_ms = ms(1, 2);
  s.gpu.compact_ms = ms(2, 3);
  s.gpu.depth_sort_ms = ms(3, 4);
  s.gpu.emit_ms = ms(4, 5);
  s.gpu.tile_sort_ms = ms(5, 6);
  s.gpu.ranges_ms = ms(6, 7);
  s.gpu.blend_ms = ms(7, 8);
  s.gpu.total_ms = ms(0, 8);
  if (v == 0) s.gpu.upload_ms = ms(kUploadBeginTimestamp, kUploadEndTimestamp);
  if (f.together && v > 0) s.gpu = {};  // within view 0's spans (its own were written for availability only)
  return s;
}

}  // namespace gauss::render
