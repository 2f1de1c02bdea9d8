// SplatRenderer: resources, the slot / mesh / tint API, and frame submission.
//
// Stereo: each eye runs the whole pass sequence for its own camera (per-eye 2D covariance,
// depth order and tiles), recorded into one command buffer after one upload. Sorting the
// depth keys once from a centre eye could only save the per-eye depth sort, because tile
// binning and the tile sort depend on each eye's footprints anyway. Measured with
// `gauss-bench render` (200k@1024x1024:stereo, box scene) on lavapipe, 2 cores, load ~1,
// three runs: GPU time per stereo frame 817-1116 ms, of which both eyes' depth sorts
// 41-62 ms (5.0-5.5 %) and both tile sorts 127-177 ms. A shared centre-eye sort would save
// at most half the depth sorts (~2.5-2.8 %) while making each eye's order differ from its
// own reference image, so each eye sorts itself. With the GPU shapes the two eyes' passes
// are recorded together, step by step, each eye with its own scratch (splat_frame.h,
// ViewScratch; docs/DESIGN.md "Stereo").
#include "gauss/render/splat_renderer.h"

#include <algorithm>
#include <cstdlib>
#include <string>
#include <string_view>

#include "gauss/engine/log_text.h"
#include "gauss/render/reference_rasterizer.h"
#include "gauss/render/vk_context.h"
#include "splat_frame.h"
#include "splat_layout.h"

namespace gauss::render {

SplatRenderer::SplatRenderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SplatRenderer::~SplatRenderer() = default;

SplatRenderer::Impl::~Impl() {
  if (context == nullptr) return;
  if (ring) (void)ring->wait_all();
  for (FrameSlot& f : frame_slots)
    for (FrameViewResources& view : f.views)
      if (view.passes != VK_NULL_HANDLE) vkFreeCommandBuffers(context->device(), context->command_pool(), 1, &view.passes);
}

namespace {

// One of the renderer's buffers (at least 16 bytes: Vulkan takes no empty buffer), named for
// validation messages and errors.
Status make_buffer(vk::Context& context, vk::Buffer& out, std::uint64_t bytes, std::string name,
                   VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                   vk::MemoryUsage memory = vk::MemoryUsage::DeviceLocal) {
  auto b = vk::Buffer::create(context, {.size = std::max<std::uint64_t>(bytes, 16), .usage = usage, .memory = memory,
                                        .name = std::move(name)});
  if (!b) return Error{"SplatRenderer: " + b.message()};
  out = std::move(*b);
  return Ok{};
}

}  // namespace

Status SplatRenderer::Impl::make_scratch(ViewScratch& s, const char* what) {
  const ViewScratchBytes& sizes = plan.view_scratch;  // what the plan counted
  ViewScratch made;
  auto make = [&](vk::Buffer& out, std::uint64_t bytes, const char* name) {
    return make_buffer(*context, out, bytes, std::string(name) + what);
  };
  for (std::uint32_t c = 0; c < plan.slot_chunks; ++c) {
    const std::uint64_t first = std::uint64_t{c} * plan.chunk_slots;
    const std::uint64_t n = std::min<std::uint64_t>(info.capacity - first, plan.chunk_slots);
    if (auto st = make(made.projected.emplace_back(), n * sizes.projected_per_slot,
                       plan.slot_chunks > 1 ? "splat projected chunk" : "splat projected");
        !st)
      return st;
  }
  const struct {
    vk::Buffer* out;
    std::uint64_t bytes;
    const char* name;
  } reqs[] = {
      {&made.tile_count, sizes.tile_counts, "splat tile counts"},
      {&made.offsets, sizes.offsets, "splat offsets"},
      {&made.tile_depth, sizes.tile_depth, "tile max mesh depth"},
      {&made.output, sizes.output, "splat output pixels"},
  };
  for (const auto& r : reqs)
    if (auto st = make(*r.out, r.bytes, r.name); !st) return st;
  if (auto st = make_sort_buffers(made, sizes, what); !st) return st;
  s = std::move(made);
  return Ok{};
}

Status SplatRenderer::Impl::make_sort_buffers(ViewScratch& s, const ViewScratchBytes& sizes, const char* what) {
  const struct {
    vk::Buffer* out;
    std::uint64_t bytes;
    const char* name;
  } reqs[] = {
      {&s.keys[0], sizes.sort_buffer, "sort keys A"},   {&s.keys[1], sizes.sort_buffer, "sort keys B"},
      {&s.vals[0], sizes.sort_buffer, "sort values A"}, {&s.vals[1], sizes.sort_buffer, "sort values B"},
      {&s.hist, sizes.histogram, "radix histogram"},
  };
  for (const auto& r : reqs)
    if (auto st = make_buffer(*context, *r.out, r.bytes, std::string(r.name) + what); !st) return st;
  return Ok{};
}

void SplatRenderer::Impl::grow_pairs() {
  // A quarter more than asked: a moving view's needs change from frame to frame, and each
  // growth records the passes anew.
  const std::uint64_t want = pairs_wanted + pairs_wanted / 4;
  pairs_wanted = 0;
  SplatRendererCreateInfo asked = info;
  asked.max_pairs = 0;
  auto grown = plan_splat_memory(device_limits, asked, want);
  if (!grown || grown->max_pairs <= info.max_pairs) return;  // no room for more: the overflow stays
  // The plan counts one view's scratch; two views recorded together grow both.
  if (scratch[1].valid() && grown->total_bytes + grown->second_view_bytes() > grown->heap_bytes) return;
  std::array<ViewScratch, 2> made;
  for (std::size_t v = 0; v < scratch.size(); ++v) {
    if (!scratch[v].valid()) continue;
    if (!make_sort_buffers(made[v], grown->view_scratch, v == 0 ? "" : " (view 1)")) {
      // The device would not give it after all: the frames go on with what there is (their
      // overflow reported), and this is not tried again.
      pairs_grow_failed = true;
      return;
    }
  }
  for (std::size_t v = 0; v < scratch.size(); ++v) {
    if (!scratch[v].valid()) continue;
    std::swap(scratch[v].keys, made[v].keys);
    std::swap(scratch[v].vals, made[v].vals);
    std::swap(scratch[v].hist, made[v].hist);
    auto old = std::make_shared<ViewScratch>(std::move(made[v]));
    ring->defer([old]() mutable { old.reset(); });  // frames in flight still sort in them
  }
  plan = *grown;
  info.max_pairs = grown->max_pairs;
  ++targets_generation;  // the recorded passes bind the old buffers and push the old capacity
}

Expected<std::unique_ptr<SplatRenderer>> SplatRenderer::create(vk::Context& context,
                                                                const SplatRendererCreateInfo& info_in) {
  // Everything the renderer will allocate is sized and checked first: a scene the device
  // cannot hold is refused here, before any buffer exists.
  const SplatDeviceLimits limits = splat_device_limits(context);
  auto plan = plan_splat_memory(limits, info_in);
  if (!plan) return plan.error();
  SplatRendererCreateInfo info = info_in;
  info.max_pairs = plan->max_pairs;

  auto impl = std::make_unique<Impl>();
  impl->plan = *plan;
  impl->context = &context;
  impl->device_limits = limits;
  impl->grow_pairs_allowed = info_in.grow_pairs.value_or(info_in.max_pairs == 0);
  auto ring = vk::FrameRing::create(context, info.frames_in_flight);
  if (!ring) return Error{"SplatRenderer: " + ring.message()};
  impl->ring = std::move(*ring);
  auto uploads = vk::StagedUploads::create(context, *impl->ring, {.scatter_min_regions = info.upload_scatter_min_regions});
  if (!uploads) return Error{"SplatRenderer: " + uploads.message()};
  impl->uploads = std::move(*uploads);
  auto slots = SlotBuffer::create(
      context, {.capacity = info.capacity, .sh_degree = info.sh_degree, .chunk_slots = plan->chunk_slots}, *impl->uploads);
  if (!slots) return Error{"SplatRenderer: " + slots.message()};
  impl->slots = std::move(*slots);
  auto mesh = MeshPass::create(context);
  if (!mesh) return mesh.error();
  impl->mesh = std::move(*mesh);
  auto profile = choose_pass_shapes(context, info.pass_shapes);
  if (!profile) return profile.error();
  impl->profile = *profile;
  auto pipes = splat::SplatPipelines::create(context, {.chunks = plan->slot_chunks, .chunk_slots = plan->chunk_slots},
                                             *profile);
  if (!pipes) return pipes.error();
  impl->pipelines = std::move(*pipes);

  impl->info = info;
  if (auto st = impl->make_scratch(impl->scratch[0], ""); !st) return st.error();
  if (info.views_together && *info.views_together != impl->profile.views_together) {
    impl->profile.views_together = *info.views_together;
    impl->profile.views_reason =
        std::string(*info.views_together ? "two views together" : "two views one after the other") + " (asked for)";
  }
  if (impl->profile.views_together && plan->total_bytes + plan->second_view_bytes() > plan->heap_bytes)
    impl->keep_views_apart("the device-local heap of " + format_bytes(plan->heap_bytes) + " cannot also hold " +
                           format_bytes(plan->second_view_bytes()) + " of second-view scratch");
  const std::uint64_t max_tiles = std::uint64_t{render::tile_count(info.max_width)} * render::tile_count(info.max_height);
  if (auto st = make_buffer(context, impl->highlight, std::uint64_t{kMaxHighlightObjects} * 4, "highlight object ids"); !st)
    return st.error();
  for (std::uint32_t v = 0; v < 2; ++v)
    if (auto st = make_buffer(context, impl->targets[v].ranges, max_tiles * 8, "splat tile ranges"); !st) return st.error();
  impl->frame_slots.resize(info.frames_in_flight);
  for (FrameSlot& f : impl->frame_slots) {
    for (FrameViewResources& view : f.views) {
      if (auto st = make_buffer(context, view.view_ubo, sizeof(gpu::GpuView), "splat view constants",
                                VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, vk::MemoryUsage::HostVisibleNearGpu);
          !st)
        return st.error();
      if (auto st = make_buffer(context, view.counters, gpu::SPLAT_COUNTER_WORDS * 4, "splat counters",
                                VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT,
                                vk::MemoryUsage::HostVisibleNearGpu);
          !st)
        return st.error();
      auto ts = vk::TimestampQueries::create(context, kViewTimestamps);
      if (!ts) return ts.error();
      view.timestamps = std::move(*ts);
      auto passes = vk::allocate_command_buffer(context, VK_COMMAND_BUFFER_LEVEL_SECONDARY);
      if (!passes) return Error{"SplatRenderer: " + passes.message()};
      view.passes = *passes;
    }
  }
  impl->reuse_passes = info.reuse_recorded_passes;
  if (const char* env = std::getenv("GAUSS_SPLAT_REUSE_PASSES"); env && std::string_view(env) == "0")
    impl->reuse_passes = false;
  return std::unique_ptr<SplatRenderer>(new SplatRenderer(std::move(impl)));
}

std::uint32_t SplatRenderer::capacity() const noexcept { return impl_->info.capacity; }
int SplatRenderer::sh_degree() const noexcept { return impl_->info.sh_degree; }
std::uint32_t SplatRenderer::max_pairs() const noexcept { return impl_->info.max_pairs; }
const SplatMemoryPlan& SplatRenderer::memory_plan() const noexcept { return impl_->plan; }
const SplatPassProfile& SplatRenderer::pass_profile() const noexcept { return impl_->profile; }

Status SplatRenderer::write_slots(std::uint32_t first_slot, std::span<const Gaussian> gaussians) {
  return impl_->slots.write_slots(first_slot, gaussians);
}
Status SplatRenderer::write_slot(SlotIndex slot, const Gaussian& gaussian) {
  return impl_->slots.write_slot(slot, gaussian);
}
SlotLayout SplatRenderer::slot_layout() const noexcept { return impl_->slots.layout(); }

Status SplatRenderer::queue_packed_slots(const vk::Buffer& source, const SlotLayout& packed_as,
                                         std::span<const PackedSlotRun> runs, std::span<const std::uint8_t> good) {
  return impl_->slots.queue_packed(source, packed_as, runs, good);
}

Status SplatRenderer::clear_slots(std::uint32_t first_slot, std::uint32_t count) {
  return impl_->slots.clear_slots(first_slot, count);
}
Status SplatRenderer::clear_slot(SlotIndex slot) { return impl_->slots.clear_slot(slot); }
std::uint32_t SplatRenderer::occupied_count() const noexcept { return impl_->slots.occupied_count(); }
std::uint32_t SplatRenderer::high_water() const noexcept { return impl_->slots.high_water(); }
std::uint64_t SplatRenderer::rejected_nonfinite() const noexcept { return impl_->slots.rejected_nonfinite(); }

Status SplatRenderer::set_mesh(const TriangleMesh& mesh) {
  return impl_->mesh.set_mesh(*impl_->context, mesh, impl_->mesh_update());
}
Status SplatRenderer::set_mesh_chunk(std::uint64_t id, const TriangleMesh& mesh) {
  return impl_->mesh.set_chunk(*impl_->context, id, mesh, impl_->mesh_update());
}
Status SplatRenderer::set_mesh_chunk(std::uint64_t id, const PreparedMeshChunk& chunk) {
  return impl_->mesh.set_chunk(*impl_->context, id, chunk, impl_->mesh_update());
}
void SplatRenderer::remove_mesh_chunk(std::uint64_t id) noexcept { impl_->mesh.remove_chunk(id, impl_->mesh_update()); }
void SplatRenderer::clear_mesh() noexcept { impl_->mesh.clear_mesh(impl_->mesh_update()); }
bool SplatRenderer::has_mesh() const noexcept { return impl_->mesh.has_mesh(); }
std::size_t SplatRenderer::mesh_chunk_count() const noexcept { return impl_->mesh.chunk_count(); }

Status SplatRenderer::set_highlight(std::span<const ObjectId> objects) {
  if (objects.size() > kMaxHighlightObjects)
    return Error{"SplatRenderer::set_highlight: " + std::to_string(objects.size()) + " objects (at most " +
                 std::to_string(kMaxHighlightObjects) + ")"};
  std::vector<std::int32_t> ids;
  ids.reserve(objects.size());
  for (ObjectId o : objects) ids.push_back(to_underlying(o));
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  if (!ids.empty()) {
    if (auto st = impl_->uploads->write(impl_->highlight, 0, ids.data(), ids.size() * sizeof(std::int32_t)); !st)
      return st;
  }
  impl_->highlight_count = static_cast<std::uint32_t>(ids.size());
  return Ok{};
}
void SplatRenderer::clear_highlight() noexcept { impl_->highlight_count = 0; }

Status SplatRenderer::set_edit_tint(SlotIndex slot, EditTintState state) {
  return set_edit_tints(to_underlying(slot), 1, state);
}
Status SplatRenderer::set_edit_tints(std::uint32_t first, std::uint32_t count, EditTintState state) {
  return impl_->slots.set_edit_tints(first, count, state, impl_->display_frame);
}
std::uint32_t SplatRenderer::display_frame() const noexcept { return impl_->display_frame; }

Expected<std::uint64_t> SplatRenderer::Impl::render_frame(std::span<const Camera> cameras,
                                                          const SplatRenderOptions& options, const FrameHooks& hooks) {
  if (cameras.empty() || cameras.size() > 2)
    return Error{"SplatRenderer: a frame has 1 or 2 views, not " + std::to_string(cameras.size())};
  for (const Camera& cam : cameras) {
    if (auto st = validate_camera(cam); !st) return Error{"SplatRenderer: " + st.message()};
    if (cam.width > info.max_width || cam.height > info.max_height)
      return Error{"SplatRenderer: camera " + std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                   " exceeds the renderer's maximum " + std::to_string(info.max_width) + "x" +
                   std::to_string(info.max_height)};
  }
  if (!std::isfinite(options.mesh_margin) || options.mesh_margin < 0.0)
    return Error{"SplatRenderer: mesh_margin must be finite and >= 0"};

  // Waits for the frame that last used this slot; its constants and counters are free.
  auto frame = ring->begin();
  if (!frame) return frame.error();
  FrameSlot& f = frame_slots[frame->index];
  if (f.serial != 0) {
    // The slot's previous frame has finished: keep its statistics before they are reused.
    std::array<SplatFrameStats, 2> prev{};
    bool ok = true;
    for (std::uint32_t v = 0; v < f.view_count && ok; ++v) {
      auto st = read_stats(f, v);
      if (st) prev[v] = *st;
      ok = st.ok();
    }
    if (ok) finished_stats[f.serial] = prev;
    while (finished_stats.size() > 2 * frame_slots.size() + 2) finished_stats.erase(finished_stats.begin());
    f.serial = 0;
    for (std::uint32_t v = 0; v < f.view_count && ok; ++v) note_needed(prev[v]);
  }
  if (grow_pairs_allowed && !pairs_grow_failed && pairs_wanted > info.max_pairs) grow_pairs();
  const auto views = static_cast<std::uint32_t>(cameras.size());
  const bool together = views == 2 && cameras[0].width == cameras[1].width && cameras[0].height == cameras[1].height &&
                        second_scratch_ready();
  auto fail = [&](const Error& e) -> Error {
    ring->abandon();
    f.serial = 0;
    return e;
  };
  for (std::uint32_t v = 0; v < views; ++v)
    if (auto st = prepare_view(f, v, cameras[v], options); !st) return fail(st.error());

  const VkCommandBuffer c = frame->cmd;
  // Earlier frames on the queue may still read what this one overwrites (targets, scratch,
  // slots): one full barrier orders this frame behind them.
  vk::memory_barrier(c, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  for (std::uint32_t v = 0; v < views; ++v) f.views[v].timestamps.reset(c);
  // The staged copies are timed in view 0's pool; view 1's upload slots are written too
  // (read-back requires every slot), bracketing nothing.
  f.views[0].timestamps.write(c, kUploadBeginTimestamp);
  uploads->record(c);
  for (std::uint32_t v = 0; v < views; ++v) {
    if (v > 0) f.views[v].timestamps.write(c, kUploadBeginTimestamp);
    f.views[v].timestamps.write(c, kUploadEndTimestamp);
  }
  for (std::uint32_t v = 0; v < views; ++v) {
    const std::uint64_t tiles = std::uint64_t{render::tile_count(cameras[v].width)} * render::tile_count(cameras[v].height);
    if (auto st = vk::record_fill(c, f.views[v].counters, 0, VK_WHOLE_SIZE, 0u); !st) return fail(st.error());
    if (auto st = vk::record_fill(c, targets[v].ranges, 0, tiles * 8, 0u); !st) return fail(st.error());
  }
  vk::transfer_to_compute_barrier(c);
  if (together) {
    const ViewWork both[2] = {{0, &cameras[0], &scratch[0]}, {1, &cameras[1], &scratch[1]}};
    if (auto st = record_views(c, f, both, options); !st) return fail(st.error());
  } else {
    for (std::uint32_t v = 0; v < views; ++v) {
      const ViewWork one{v, &cameras[v], &scratch[0]};
      if (auto st = record_views(c, f, std::span(&one, 1), options); !st) return fail(st.error());
    }
  }
  if (hooks.record_after)
    if (auto st = hooks.record_after(c); !st) return fail(st.error());
  vk::memory_barrier(c, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                     VK_ACCESS_2_HOST_READ_BIT);
  if (hooks.submit) {
    if (auto st = ring->end(); !st) return fail(st.error());
    if (auto st = hooks.submit(c, frame->fence); !st) return fail(st.error());
    ring->submitted();
  } else if (auto st = ring->submit(); !st) {
    f.serial = 0;
    return st.error();
  }
  uploads->submitted();
  f.serial = frame->serial;
  f.view_count = views;
  f.together = together;
  f.high_water = slots.high_water();
  f.max_pairs = info.max_pairs;
  ++display_frame;
  return frame->serial;
}

void SplatRenderer::Impl::keep_views_apart(const std::string& why) {
  profile.views_together = false;
  profile.views_reason = "two views one after the other: " + why;
}

bool SplatRenderer::Impl::second_scratch_ready() {
  if (!profile.views_together) return false;
  if (scratch[1].valid()) return true;
  if (auto st = make_scratch(scratch[1], " (view 1)"); !st) {
    keep_views_apart(st.message());
    return false;
  }
  return true;
}

Expected<std::array<SplatFrameStats, 2>> SplatRenderer::Impl::frame_stats(std::uint64_t serial) {
  if (auto kept = finished_stats.find(serial); kept != finished_stats.end()) return kept->second;
  const FrameSlot* f = nullptr;
  for (const FrameSlot& s : frame_slots)
    if (s.serial == serial && serial != 0) f = &s;
  if (f == nullptr)
    return Error{"SplatRenderer::frame_stats: frame " + std::to_string(serial) +
                 " is not among the frames in flight or just finished"};
  if (auto st = ring->wait(serial); !st) return st.error();
  std::array<SplatFrameStats, 2> out{};
  for (std::uint32_t v = 0; v < f->view_count; ++v) {
    auto s = read_stats(*f, v);
    if (!s) return s.error();
    out[v] = *s;
    note_needed(*s);
  }
  return out;
}

Expected<std::uint64_t> SplatRenderer::render_frame(std::span<const Camera> cameras, const SplatRenderOptions& options,
                                                    const FrameHooks& hooks) {
  return impl_->render_frame(cameras, options, hooks);
}

Expected<std::array<SplatFrameStats, 2>> SplatRenderer::frame_stats(std::uint64_t serial) {
  return impl_->frame_stats(serial);
}

vk::FrameRing& SplatRenderer::frames() noexcept { return *impl_->ring; }
vk::StagedUploads& SplatRenderer::uploads() noexcept { return *impl_->uploads; }

Expected<SplatFrameStats> SplatRenderer::render(const Camera& camera, const SplatRenderOptions& options) {
  auto serial = impl_->render_frame(std::span<const Camera>(&camera, 1), options, {});
  if (!serial) return serial.error();
  auto r = impl_->frame_stats(*serial);
  if (!r) return r.error();
  return (*r)[0];
}

Expected<std::array<SplatFrameStats, 2>> SplatRenderer::render_stereo(const Camera& left, const Camera& right,
                                                                     const SplatRenderOptions& options) {
  const Camera cams[2] = {left, right};
  auto serial = impl_->render_frame(cams, options, {});
  if (!serial) return serial.error();
  return impl_->frame_stats(*serial);
}

vk::OffscreenTarget& SplatRenderer::target(std::uint32_t view) { return impl_->targets[std::min(view, 1u)].target; }

Expected<ImageRGBA8> SplatRenderer::read_image(std::uint32_t view) {
  if (view > 1) return Error{"SplatRenderer::read_image: view " + std::to_string(view) + " (0 or 1)"};
  if (auto st = impl_->ring->wait_all(); !st) return st.error();
  vk::OffscreenTarget& t = impl_->targets[view].target;
  if (!t.color().valid()) return Error{"SplatRenderer::read_image: view " + std::to_string(view) + " not rendered yet"};
  return t.read_color(*impl_->context);
}

Expected<std::vector<float>> SplatRenderer::read_mesh_depth(std::uint32_t view) {
  if (view > 1) return Error{"SplatRenderer::read_mesh_depth: view " + std::to_string(view) + " (0 or 1)"};
  if (auto st = impl_->ring->wait_all(); !st) return st.error();
  ViewTarget& v = impl_->targets[view];
  if (!v.target.depth().valid())
    return Error{"SplatRenderer::read_mesh_depth: view " + std::to_string(view) + " not rendered yet"};
  const std::size_t n = std::size_t{v.target.width()} * v.target.height();
  if (!v.had_mesh) return std::vector<float>(n, std::numeric_limits<float>::infinity());
  auto stored = v.target.read_depth(*impl_->context);
  if (!stored) return stored.error();
  for (float& d : *stored) d = MeshPass::stored_to_view_depth(d);
  return stored;
}

}  // namespace gauss::render
