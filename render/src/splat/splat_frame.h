#pragma once
// Internal state of SplatRenderer (render/src/splat only): the GPU buffers of a frame and
// the recording of one view's passes.
#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <map>
#include <optional>
#include <span>
#include <vector>

#include "gauss/engine/camera.h"
#include "gauss/render/mesh_pass.h"
#include "gauss/render/slot_buffer.h"
#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_commands.h"
#include "gauss/render/vk_frame_ring.h"
#include "gauss/render/vk_staged_uploads.h"
#include "gauss/render/vk_image.h"
#include "gauss/render/vk_timestamps.h"
#include "splat_pipelines.h"

namespace gauss::render {

// Timestamp slots of one view (the passes of SplatPassTimings, in order), plus two around
// the frame's staged uploads (view 0's pool only).
inline constexpr std::uint32_t kViewTimestamps = 11;
inline constexpr std::uint32_t kUploadBeginTimestamp = 9;
inline constexpr std::uint32_t kUploadEndTimestamp = 10;

// What a view keeps across frames: the image it renders into (read by a presenter or a
// readback after the frame) and GPU-only scratch. Frames in flight share these: the queue
// runs frames in order and every frame starts behind a full barrier.
struct ViewTarget {
  vk::OffscreenTarget target;
  vk::Buffer ranges;     // uvec2 per tile
  bool had_mesh{false};
};

// What a view's compute passes record besides the buffers and pipelines fixed at creation.
// The camera is not in it: the passes read it from the view's uniform buffer, so a moving
// camera replays the same commands. Equal keys record equal commands.
struct ViewPassesKey {
  std::uint32_t width{0}, height{0}, high_water{0};
  bool mesh{false}, tint{false}, exact_culling{false};
  std::uint64_t targets_generation{0};  // a replaced target image or ranges buffer
  bool together{false};                 // both views' passes, step by step (record_views)
  bool operator==(const ViewPassesKey&) const = default;
};

// GPU-only scratch of a view's passes, from the projected splats to the packed pixels.
// Views recorded one after the other share one set (barriers order them); views recorded
// together need one each.
struct ViewScratch {
  std::vector<vk::Buffer> projected;  // GpuProjected per slot, one buffer per slot chunk
  vk::Buffer tile_count;  // uint per slot
  vk::Buffer offsets;     // uint per slot / per visible splat
  std::array<vk::Buffer, 2> keys;  // ping-pong sort keys, max(capacity, max_pairs)
  std::array<vk::Buffer, 2> vals;
  vk::Buffer hist;        // bins * blocks + bins (radix_histogram_bytes); the GPU scans' block sums
  vk::Buffer tile_depth;  // float per tile
  vk::Buffer output;      // packed RGBA8 per pixel
  bool valid() const { return !projected.empty(); }
};

// One view's part of a recording: which view, its camera and its scratch.
struct ViewWork {
  std::uint32_t v{0};
  const Camera* camera{nullptr};
  ViewScratch* scratch{nullptr};
};

// What the CPU writes before or reads after a frame: one set per frame in flight.
struct FrameViewResources {
  vk::Buffer view_ubo;   // GpuView, host visible (device-local where offered)
  vk::Buffer counters;   // SPLAT_COUNTER_WORDS, host visible (stats after the frame), indirect args
  vk::TimestampQueries timestamps;
  // The view's compute passes as a secondary command buffer, replayed while passes_key
  // holds (recording them cost an H100 frame 0.1 ms of CPU while the GPU waited). Views
  // recorded together use view 0's.
  VkCommandBuffer passes{VK_NULL_HANDLE};
  std::optional<ViewPassesKey> passes_key;  // what `passes` holds; nullopt: nothing valid
  bool replayed{false};                     // the last frame here replayed `passes`
};

struct FrameSlot {
  std::array<FrameViewResources, 2> views;
  std::uint64_t serial{0};  // frame recorded here last (0 = none)
  std::uint32_t view_count{0};
  bool together{false};  // its two views were recorded together
  std::uint32_t high_water{0};
  std::uint32_t max_pairs{0};  // the pairs each of its views could hold
};

struct SplatRenderer::Impl {
  ~Impl();  // frees the views' secondary command buffers once the GPU is done with them
  vk::Context* context{nullptr};
  SplatRendererCreateInfo info;
  // Declared first, destroyed last: the uploads and slot writes refer to it.
  std::unique_ptr<vk::FrameRing> ring;
  std::unique_ptr<vk::StagedUploads> uploads;
  SlotBuffer slots;
  MeshPass mesh;
  splat::SplatPipelines pipelines;

  SplatMemoryPlan plan;
  SplatPassProfile profile;
  // scratch[0]: every view recorded alone. scratch[1]: view 1 when the two views are
  // recorded together, made at the first such frame (a renderer that never renders two
  // views together never holds it).
  std::array<ViewScratch, 2> scratch;
  // profile.views_together says whether two views of one size are recorded together: the
  // pass shapes' choice, while the heap holds the second scratch and making it has not
  // failed (keep_views_apart turns it off and says why in profile.views_reason).
  void keep_views_apart(const std::string& why);
  // Whether scratch[1] is there for two views recorded together (made at the first call).
  bool second_scratch_ready();
  vk::Buffer highlight;   // sorted object ids
  std::uint32_t highlight_count{0};
  std::uint32_t display_frame{0};
  std::array<ViewTarget, 2> targets;
  std::vector<FrameSlot> frame_slots;  // one per frame in flight
  // Statistics of finished frames whose slot was reused before anyone asked for them
  // (read when the slot is reused; the newest few kept).
  std::map<std::uint64_t, std::array<SplatFrameStats, 2>> finished_stats;

  MeshUpdate mesh_update() { return MeshUpdate{uploads.get(), ring.get()}; }
  // Whether preprocess tints (highlight or edit tints): one definition for the passes and
  // for the key that says when they must be recorded again.
  bool tint_active() const { return highlight_count > 0 || slots.tinted_count() > 0; }
  std::uint64_t targets_generation{0};  // bumped whenever a view's target is replaced
  bool reuse_passes{true};              // SplatRendererCreateInfo::reuse_recorded_passes
  // Records `views` (one, or two of one size together) into the frame's command buffer
  // `c` with frame slot `f`'s constants and counters: each view's mesh pass and layouts,
  // then the compute passes (record_passes: replayed from the first view's secondary
  // command buffer when its key still holds), then the copies into the views' images.
  // Together, every step of the passes is recorded for each view between the same two
  // barriers. Errors only for resources that fail to bind.
  Status record_views(VkCommandBuffer c, FrameSlot& f, std::span<const ViewWork> views,
                      const SplatRenderOptions& options);
  Status record_passes(VkCommandBuffer c, FrameSlot& f, std::span<const ViewWork> views,
                       const SplatRenderOptions& options);
  // Makes `s` for the create info's capacity and sizes; `what` names its buffers.
  Status make_scratch(ViewScratch& s, const char* what);
  // Makes the sort keys, values and histogram of `s` at `sizes`.
  Status make_sort_buffers(ViewScratch& s, const ViewScratchBytes& sizes, const char* what);
  // Pairs grow (SplatRendererCreateInfo::grow_pairs, by default with automatic pairs) once a
  // finished frame shows that a view needed more than they hold: note_needed keeps the most
  // any view needed, and the next frame's grow_pairs makes sort buffers for that and a
  // quarter more, as far as the memory plan's bounds allow. Frames in flight keep the old
  // buffers until they finish; the recorded passes are recorded anew. Until then (and beyond
  // the bounds) the overflow drops the farthest splats' pairs and is reported.
  bool grow_pairs_allowed{false};
  bool pairs_grow_failed{false};  // the device refused an allocation: not tried again
  std::uint64_t pairs_wanted{0};
  SplatDeviceLimits device_limits;
  void note_needed(const SplatFrameStats& s) {
    if (s.pairs_needed > s.pairs) pairs_wanted = std::max<std::uint64_t>(pairs_wanted, s.pairs_needed);
  }
  void grow_pairs();
  Status prepare_view(FrameSlot& f, std::uint32_t v, const Camera& camera, const SplatRenderOptions& options);
  Expected<SplatFrameStats> read_stats(const FrameSlot& f, std::uint32_t v) const;
  Expected<std::uint64_t> render_frame(std::span<const Camera> cameras, const SplatRenderOptions& options,
                                       const FrameHooks& hooks);
  Expected<std::array<SplatFrameStats, 2>> frame_stats(std::uint64_t serial);
};

}  // namespace gauss::render
