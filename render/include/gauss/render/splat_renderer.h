#pragma once
// gauss::render::SplatRenderer: the Vulkan compute splat renderer used by both the host
// ("server render") and the client, so the same slots + camera give the same bytes.
//
// Per view, all on the GPU with no readback inside the frame (sizes come from the slot
// capacity, the pair capacity and indirect dispatches):
//   mesh pass (only with a mesh) -> per-tile max mesh depth -> preprocess (one thread per
//   slot below the high-water mark) -> scan + compact -> stable radix sort of the N visible
//   splats by float depth (32 key bits) -> scan of tile counts in depth order -> emit
//   (tile, slot) pairs -> stable radix sort by tile id (only the bits of the tile count)
//   -> tile ranges -> blend (one workgroup per 16x16 tile). Equal depths keep slot order.
// The math is splat_math.h (the CPU reference rasterizer is the oracle).
//
// Pair overflow: when a view needs more (tile, splat) pairs than max_pairs, the pairs of
// the farthest splats are dropped (the emitted pairs follow depth order), deterministically;
// SplatFrameStats::pair_overflow and pairs_needed report it. Never garbage. Where the pairs
// grow (grow_pairs, the default with automatic pairs), the frames after the overflow was
// seen hold what the view needed, within the memory plan's bounds.
//
// Frames in flight: render_frame() records and submits a frame without waiting for it
// (frames_in_flight of them may run at once; the renderer's FrameRing paces them), and
// frame_stats() reads a finished frame's counters and timestamps. render() and
// render_stereo() are the blocking form (render_frame, then wait). Slot, tint, highlight
// and mesh changes between frames never race the GPU: they go through the staging ring
// and are copied at the start of the next frame, and replaced buffers are destroyed after
// the frames that used them. One thread.
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <volk.h>

#include <glm/vec3.hpp>

#include "gauss/engine/camera.h"
#include "gauss/engine/gaussian.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/image_io.h"
#include "gauss/engine/mesh.h"
#include "gauss/engine/result.h"
#include "gauss/render/splat_math.h"
#include "gauss/render/slot_buffer.h"
#include "gauss/render/splat_memory_plan.h"
#include "gauss/render/vk_staged_uploads.h"

namespace gauss::vk {
class Context;
class FrameRing;
class OffscreenTarget;
}  // namespace gauss::vk

namespace gauss::render {

struct PreparedMeshChunk;  // mesh_pass.h

inline constexpr std::uint32_t kMaxHighlightObjects = 65'536;

// The shapes of the compute passes (scans, radix count and scatter), chosen once when the
// renderer is created; the image is the same byte for byte either way (docs/DESIGN.md
// "What lavapipe charges" and "What GPUs charge").
enum class SplatPassShapes : std::uint8_t {
  // From the device: Cpu on CPU Vulkan (lavapipe), Gpu on every other device type. The
  // environment variable GAUSS_PASS_SHAPES=cpu|gpu overrides it (tests, benchmarks).
  Auto,
  // Long contiguous runs per thread: 32 keys per radix thread, one-workgroup scans. On
  // lavapipe every non-constant load is a loop over the lanes, so fewer, longer threads win.
  Cpu,
  // One element per invocation per iteration (consecutive invocations on consecutive
  // words), ranks by subgroup ballot, multi-workgroup reduce-then-scan. Needs subgroups of
  // 4..128 invocations.
  Gpu,
};
const char* pass_shapes_name(SplatPassShapes shapes) noexcept;  // "auto", "cpu", "gpu"

// The shapes a renderer on `context` takes and why (one line, e.g. "gpu (discrete GPU,
// subgroup 32, 48 KiB shared)").
struct SplatPassProfile {
  SplatPassShapes shapes{SplatPassShapes::Cpu};
  // Radix digit width: 4 (CPU shapes; GPU shapes where 8-bit rows do not fit shared
  // memory) or 8 (GPU shapes: half the passes). GAUSS_SORT_RADIX_BITS=4|8 overrides it
  // for the GPU shapes when it fits (benchmarks compare the two on one device).
  std::uint32_t radix_bits{4};
  // Shared rows of the GPU radix scatter: SPLAT_WORKGROUP / the smallest subgroup.
  std::uint32_t sort_rows{64};
  // Two views of one size (stereo) recorded together: each step of the passes for both
  // views between the same two barriers, each view with its own scratch (made at the first
  // such frame; SplatMemoryPlan::second_view_bytes()). A GPU then overlaps the two views'
  // small dispatches (the scans' one-workgroup steps) and pays each barrier once per pair.
  // GPU shapes only: lavapipe runs dispatches one after another, so it would pay the
  // memory for nothing. GAUSS_SPLAT_STEREO=together|apart overrides it (benchmarks, tests).
  bool views_together{false};
  std::string reason;        // the shapes and digits, and why
  std::string views_reason;  // how two views are recorded, and why
};
// Resolves `requested` (Auto: GAUSS_PASS_SHAPES, else the device type). Errors:
// GAUSS_PASS_SHAPES set to anything but cpu or gpu; Gpu asked of a device whose subgroups
// are outside 4..128 (both named).
Expected<SplatPassProfile> choose_pass_shapes(const vk::Context& context, SplatPassShapes requested);

struct SplatRendererCreateInfo {
  // Slots, 1 .. what the device holds (splat_memory_plan.h: the binding range, the
  // allocation size and the device-local heap decide; max_splat_capacity() says).
  std::uint32_t capacity{0};
  int sh_degree{0};             // 0..3, SH rest stored and evaluated up to this degree
  std::uint32_t max_width{1280};
  std::uint32_t max_height{720};
  // (tile, splat) pairs one view may hold; 0 = automatic (16 per slot from 1M, past 32M only
  // where the bindings and half the heap left free hold them: plan_splat_memory).
  std::uint32_t max_pairs{0};
  // Whether the pairs grow once a finished frame shows that a view needed more (to that and
  // a quarter more, within the same bounds as automatic pairs; the frames recorded before
  // drop their farthest splats' pairs and report it). Unset: when max_pairs is automatic.
  std::optional<bool> grow_pairs{};
  // Frames that may be in flight at once (1 .. vk::kMaxFramesInFlight). A display loop
  // uses 2 so that recording frame k+1 overlaps the GPU work of frame k.
  std::uint32_t frames_in_flight{1};
  // The most bytes one storage binding may cover; 0 = the device's maxStorageBufferRange.
  // A smaller value splits the per-slot arrays into chunks sooner (tests exercise the
  // split on small scenes with it).
  std::uint64_t max_binding_bytes{0};
  // Pass shapes (see SplatPassShapes); Auto lets the device and GAUSS_PASS_SHAPES decide.
  SplatPassShapes pass_shapes{SplatPassShapes::Auto};
  // Upload copy groups of at least this many regions are applied by one compute scatter
  // (vk_staged_uploads.h); UINT32_MAX keeps every group a vkCmdCopyBuffer (to compare).
  std::uint32_t upload_scatter_min_regions{vk::kDeviceScatterMinRegions};
  // Replay a view's compute passes from the command buffer they were last recorded into
  // while nothing they record has changed (size, high-water mark, mesh, tint, culling;
  // the camera travels in a uniform buffer). false, or GAUSS_SPLAT_REUSE_PASSES=0,
  // records them every frame (the same commands: tests and benchmarks compare the two).
  bool reuse_recorded_passes{true};
  // Two views of one size recorded together (true) or one after the other (false);
  // unset: the pass profile's choice (SplatPassProfile::views_together). The images are
  // the same byte for byte either way.
  std::optional<bool> views_together{};
};

// What a frame-paced caller adds to a frame of render_frame().
struct FrameHooks {
  // Recorded into the frame's command buffer after every view's passes (e.g. copy a view
  // into a swapchain image, draw UI). An error abandons the frame.
  std::function<Status(VkCommandBuffer)> record_after;
  // Submits the ended command buffer, signalling `fence` (e.g. with swapchain
  // semaphores). Empty: a plain queue submission.
  std::function<Status(VkCommandBuffer cmd, VkFence fence)> submit;
};

struct SplatRenderOptions {
  glm::vec3 clear_colour{0.0f};         // background without a mesh (and the mesh clear colour)
  double mesh_margin{kDefaultMeshMargin};
  // Bin splats only into tiles where alpha can reach 1/255 (never changes the image;
  // off for measurements and for the equivalence test).
  bool exact_culling{true};
};

// Milliseconds of GPU time per pass (timestamps), for one view.
struct SplatPassTimings {
  double mesh_ms{0.0};        // mesh pass + tile max depth
  double preprocess_ms{0.0};
  double compact_ms{0.0};     // visibility scan + compaction
  double depth_sort_ms{0.0};
  double emit_ms{0.0};        // pair scan + emit
  double tile_sort_ms{0.0};
  double ranges_ms{0.0};
  double blend_ms{0.0};       // blend + copy into the target
  double total_ms{0.0};       // mesh .. blend (the view's passes)
  double upload_ms{0.0};      // the frame's staged copies (slots, tints, chunks); view 0 only
};

struct SplatFrameStats {
  std::uint32_t high_water{0};
  std::uint32_t visible{0};          // splats binned into >= 1 tile
  std::uint32_t pairs{0};            // pairs emitted (<= max_pairs)
  std::uint32_t pairs_needed{0};     // pairs wanted (saturates at 2^32 - 1)
  bool pair_overflow{false};
  bool passes_replayed{false};       // the compute passes were replayed, not recorded anew
  // This view's passes were recorded together with the other view's (SplatPassProfile::
  // views_together): view 0's timings cover both views' passes and view 1's are zero, so
  // sums over the views stay right.
  bool views_together{false};
  SplatPassTimings gpu;
};

class SplatRenderer {
 public:
  // Errors: capacity 0, sh_degree outside 0..3, a zero or over-limit max size, a scene
  // the device cannot hold (plan_splat_memory's message: the limit, what the renderer
  // needs, the most slots the device holds; checked before anything is allocated),
  // Vulkan failures (all named).
  static Expected<std::unique_ptr<SplatRenderer>> create(vk::Context& context, const SplatRendererCreateInfo& info);
  ~SplatRenderer();
  SplatRenderer(const SplatRenderer&) = delete;
  SplatRenderer& operator=(const SplatRenderer&) = delete;

  std::uint32_t capacity() const noexcept;
  int sh_degree() const noexcept;
  std::uint32_t max_pairs() const noexcept;
  // The sizes it was made with: slot chunks, bytes per slot, total bytes.
  const SplatMemoryPlan& memory_plan() const noexcept;
  // The pass shapes it was made with, and why.
  const SplatPassProfile& pass_profile() const noexcept;

  // ---- Slots (see slot_buffer.h: non-finite Gaussians are refused and counted) ----
  Status write_slots(std::uint32_t first_slot, std::span<const Gaussian> gaussians);
  Status write_slot(SlotIndex slot, const Gaussian& gaussian);
  Status clear_slots(std::uint32_t first_slot, std::uint32_t count);
  Status clear_slot(SlotIndex slot);
  // Slots packed elsewhere (SlotBuffer::queue_packed: pack_slots with slot_layout(), into a
  // host-visible buffer the caller keeps until the frame that copies them has finished).
  SlotLayout slot_layout() const noexcept;
  Status queue_packed_slots(const vk::Buffer& source, const SlotLayout& packed_as, std::span<const PackedSlotRun> runs,
                            std::span<const std::uint8_t> good);
  std::uint32_t occupied_count() const noexcept;
  std::uint32_t high_water() const noexcept;
  std::uint64_t rejected_nonfinite() const noexcept;

  // ---- Mesh layer (mesh_pass.h: chunks by id, drawn in id order) ----
  Status set_mesh(const TriangleMesh& mesh);  // the only chunk
  Status set_mesh_chunk(std::uint64_t id, const TriangleMesh& mesh);  // add / replace
  Status set_mesh_chunk(std::uint64_t id, const PreparedMeshChunk& chunk);  // prepare_mesh_chunk's
  void remove_mesh_chunk(std::uint64_t id) noexcept;
  void clear_mesh() noexcept;
  bool has_mesh() const noexcept;
  std::size_t mesh_chunk_count() const noexcept;

  // ---- Tints (splat_math.h "Tints") ----
  // Errors: more than kMaxHighlightObjects ids. Duplicates are fine.
  Status set_highlight(std::span<const ObjectId> objects);
  void clear_highlight() noexcept;
  // Edit visualisation of one slot; state.age is its age at the NEXT rendered frame
  // (every render / render_stereo call advances the display frame by one).
  Status set_edit_tint(SlotIndex slot, EditTintState state);
  // The same state for slots [first, first + count) (one staged write).
  Status set_edit_tints(std::uint32_t first, std::uint32_t count, EditTintState state);
  std::uint32_t display_frame() const noexcept;

  // ---- Frames ----
  // Records 1 or 2 views (view v into target(v)) and submits them without waiting;
  // returns the frame's serial. Waits only for the frame that used the same frame slot
  // frames_in_flight frames ago. Errors: as render(), a hook's error; the frame is then
  // not submitted and the pending writes stay queued for the next one.
  Expected<std::uint64_t> render_frame(std::span<const Camera> cameras, const SplatRenderOptions& options = {},
                                       const FrameHooks& hooks = {});
  // Statistics of a finished frame (blocks until it has finished). Errors: a serial never
  // submitted, or one whose frame slot was reused since (read within frames_in_flight).
  Expected<std::array<SplatFrameStats, 2>> frame_stats(std::uint64_t serial);
  vk::FrameRing& frames() noexcept;
  vk::StagedUploads& uploads() noexcept;

  // Renders one view into target(0). Errors: invalid camera (validate_camera), a size
  // above max_width x max_height, Vulkan failures.
  Expected<SplatFrameStats> render(const Camera& camera, const SplatRenderOptions& options = {});
  // Left eye into target(0), right eye into target(1), one submission, one upload.
  // Each eye is preprocessed and sorted for its own camera (see the .cpp for the figures).
  Expected<std::array<SplatFrameStats, 2>> render_stereo(const Camera& left, const Camera& right,
                                                         const SplatRenderOptions& options = {});
  // The image of view 0/1 of the last frame (RGBA8 colour, depth = mesh depth attachment).
  // A hook may read it in the frame's command buffer; from the CPU, wait for the frame.
  vk::OffscreenTarget& target(std::uint32_t view = 0);
  // Waits for every frame in flight first.
  Expected<ImageRGBA8> read_image(std::uint32_t view = 0);
  // Mesh view depth (metres, +infinity where no triangle) of view 0/1 of the last frame;
  // all +infinity when the frame had no mesh.
  Expected<std::vector<float>> read_mesh_depth(std::uint32_t view = 0);

  struct Impl;

 private:
  explicit SplatRenderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace gauss::render
