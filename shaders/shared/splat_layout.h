// Layout of the compute splat renderer (render/src/splat/, shaders/splat_*.comp,
// shaders/sort_radix_*.comp, shaders/mesh.*): GPU structs, bindings, workgroup sizes,
// specialization constant ids and the splat-math constants the shaders need. Included
// by GLSL and C++; render/src/splat/splat_pipelines.cpp static_asserts that the
// math constants equal those of render/include/gauss/render/splat_math.h.
//
// Pass sequence per view (all on the GPU, no readback inside a frame):
//   mesh (graphics) -> tile max depth (mesh only) -> preprocess (one thread per slot up
//   to the high-water mark) -> scan + compact (visible slots in slot order) -> depth
//   radix sort (stable, 32-bit float keys over the N visible) -> scan of tile counts
//   in depth order -> emit (tile id, slot) pairs -> tile radix sort (stable, only the
//   bits of the tile id) -> tile ranges -> blend (one workgroup per 16x16 tile).
// Because both sorts are stable and the compacted list is in slot order, pairs of one
// tile end up ordered by (depth key, slot): the deterministic order of splat_math.h.
#ifndef GAUSS_SHADERS_SHARED_SPLAT_LAYOUT_H
#define GAUSS_SHADERS_SHARED_SPLAT_LAYOUT_H

#include "glsl_cpp.h"

GAUSS_SHARED_BEGIN

// ---- Workgroups ----------------------------------------------------------------------
// Threads of every 1-D kernel (preprocess, compact, emit, ranges, scan).
GAUSS_CONST(uint, SPLAT_WORKGROUP, 256u)
// Screen tile edge; the blend runs one SPLAT_TILE x SPLAT_TILE workgroup per tile.
GAUSS_CONST(uint, SPLAT_TILE, 16u)
// Blend: a workgroup of SPLAT_BLEND_THREADS invocations per tile, each blending one column
// of SPLAT_BLEND_PIXELS pixels (invocation i: column i % 16, rows 8 * (i / 16) ...).
GAUSS_CONST(uint, SPLAT_BLEND_PIXELS, 8u)
GAUSS_CONST(uint, SPLAT_BLEND_THREADS, 32u)  // SPLAT_TILE * SPLAT_TILE / SPLAT_BLEND_PIXELS
// Radix sort: 4-bit digits (16 bins). CPU shapes (SplatPassShapes::Cpu, the lavapipe ones):
// every thread owns SORT_ITEMS consecutive keys, so one workgroup sorts a block of
// SORT_BLOCK keys; no subgroup operation is used: the per-block ranking goes through shared
// memory, correct at any subgroup size. The GPU shapes follow below.
GAUSS_CONST(uint, SORT_RADIX_BITS, 4u)
GAUSS_CONST(uint, SORT_BINS, 16u)
// 32 keys per thread: lavapipe pays a fixed cost per thread and per workgroup of each pass
// (sorts at box 1M@1280x720: depth 96 -> 54 ms, tile 268 -> 164 ms against 8 keys).
GAUSS_CONST(uint, SORT_ITEMS, 32u)
GAUSS_CONST(uint, SORT_BLOCK, 8192u)  // SPLAT_WORKGROUP * SORT_ITEMS
// GPU pass shapes (SplatPassShapes::Gpu: splat_scan_gpu.comp, sort_radix_*_gpu.comp; the
// CPU shapes above are unchanged). A GPU wants consecutive invocations on consecutive
// words: every loop takes one key per invocation per iteration, SORT_ITEMS_GPU iterations
// per workgroup, and ranks within a subgroup by ballot. 16 keys x 256 invocations = 4096
// keys per radix block and per scan block: 1M keys make 256 workgroups (an H100 has 132
// SMs); the histogram is scanned by one workgroup per digit (sort_radix_offsets_gpu.comp).
GAUSS_CONST(uint, SORT_ITEMS_GPU, 16u)
GAUSS_CONST(uint, SORT_BLOCK_GPU, 4096u)  // SPLAT_WORKGROUP * SORT_ITEMS_GPU
// The most subgroups of one SPLAT_WORKGROUP workgroup: 256 / the smallest subgroup (4).
// Shared arrays per subgroup are sized for it, so any subgroup size 4..128 fits.
GAUSS_CONST(uint, SPLAT_MAX_SUBGROUPS, 64u)
// GPU shapes' digit width: 8 bits (4 passes over a depth key) where the scatter's shared
// rows fit, 4 bits elsewhere (splat_pass_shapes.cpp). Each pass is three dispatches
// (count, per-digit offsets, scatter) whose fixed cost dominates small scenes on a GPU
// (H100: 0.25 ms of 8 passes at 6k keys), so halving the passes halves it. The histogram
// buffer is sized for the widest digit: SORT_BINS_MAX words per block plus one total per
// digit (radix_histogram_bytes).
GAUSS_CONST(uint, SORT_RADIX_BITS_MAX, 8u)
GAUSS_CONST(uint, SORT_BINS_MAX, 256u)
// Indirect dispatches larger than this many workgroups wrap into the y dimension
// (maxComputeWorkGroupCount[0] is only guaranteed to be 65535).
GAUSS_CONST(uint, SPLAT_DISPATCH_ROW, 16384u)

// ---- Splat math (mirrors splat_math.h; checked on the C++ side) -----------------------
GAUSS_CONST(float, SPLAT_DILATION, 0.3)
GAUSS_CONST(float, SPLAT_FRUSTUM_CLAMP, 1.3)
GAUSS_CONST(float, SPLAT_NEAR_CULL, 0.2)
GAUSS_CONST(float, SPLAT_LAMBDA_FLOOR, 0.1)
GAUSS_CONST(float, SPLAT_SIGMA_EXTENT, 3.0)
GAUSS_CONST(float, SPLAT_ALPHA_MIN, 1.0 / 255.0)
GAUSS_CONST(float, SPLAT_ALPHA_MAX, 0.99)
GAUSS_CONST(float, SPLAT_T_STOP, 0.0001)
GAUSS_CONST(float, SPLAT_HIGHLIGHT_STRENGTH, 0.5)
GAUSS_CONST(float, SPLAT_EDIT_STRENGTH, 0.6)
GAUSS_CONST(uint, SPLAT_EDIT_TINT_FRAMES, 8u)
GAUSS_CONST(uint, SPLAT_REMOVED_FADE_FRAMES, 8u)
// Mesh view depth is stored in the D32 depth attachment as depth / SPLAT_MESH_DEPTH_SCALE
// (a power of two, so the division and the multiplication back are exact); a stored 1.0
// (the clear value) means "no triangle" and reads as +infinity.
GAUSS_CONST(float, SPLAT_MESH_DEPTH_SCALE, 65536.0)

// ---- Per-slot data ----------------------------------------------------------------------
// Core attributes of one slot (64 bytes; 1M slots = 64 MB). SH rest lives in two buffers of
// its own, split by band so that no array needs more than 96 bytes per slot (one
// 180-byte-per-slot buffer would fill a 128 MiB binding at ~745k slots):
//   SPLAT_BINDING_SH       coefficients 1..8 (bands 1-2), 3 * min(sh_rest_count, 8) floats/slot
//   SPLAT_BINDING_SH_HIGH  coefficients 9..15 (band 3), SPLAT_SH_HIGH_STRIDE floats/slot,
//                          bound and read only at degree 3
// Both are coefficient-major RGB per slot.
//
// Slot chunks: when one of the wide per-slot arrays (core, SH, SH band 3, projected) would
// exceed the device's maxStorageBufferRange, each of them is split into up to
// SPLAT_MAX_SLOT_CHUNKS buffers of 2^SLOT_CHUNK_SHIFT slots (render/src/splat/
// splat_memory_plan.cpp chooses). Passes over slots in order (preprocess, compact) are
// dispatched once per chunk with that chunk's buffers bound (GpuSplatPush::first_slot);
// passes that read projected splats by slot (emit, blend) bind every chunk and select with
// splat_projected.glsl. With one chunk (every scene that fits one binding) the selection is
// specialised away: the shaders are those of the unsplit layout.
GAUSS_CONST(uint, SPLAT_MAX_SLOT_CHUNKS, 4u)
struct GpuSplatCore {
  vec4 position_opacity;  // xyz position (m), w opacity logit
  vec4 rotation;          // unit quaternion w, x, y, z
  vec4 log_scale_dc_r;    // xyz log scale, w sh_dc.r
  vec2 dc_gb;             // sh_dc.g, sh_dc.b
  int object;             // ObjectId, -1 = none
  uint flags;             // SPLAT_FLAG_*
};
GAUSS_CONST(uint, SPLAT_FLAG_OCCUPIED, 1u)
GAUSS_CONST(uint, SPLAT_SH_LOW_COEFFS, 8u)     // coefficients of bands 1-2
GAUSS_CONST(uint, SPLAT_SH_HIGH_STRIDE, 21u)   // 7 band-3 coefficients x RGB

// Edit-visualisation word per slot: kind in the top 2 bits (EditTintKind), the display
// frame of the edit in the low 30 bits; age = (frame - edit_frame) & SPLAT_EDIT_FRAME_MASK.
GAUSS_CONST(uint, SPLAT_EDIT_KIND_SHIFT, 30u)
GAUSS_CONST(uint, SPLAT_EDIT_FRAME_MASK, 0x3FFFFFFFu)

// A slot after preprocess (per view; valid only where tile_count[slot] > 0).
struct GpuProjected {
  vec4 centre_depth_opacity;  // u, v (pixels), view depth t.z, opacity after tints
  vec4 conic;                 // A, B, C, unused
  vec4 colour;                // rgb after SH, clamp and tints; unused w
  uvec4 rect;                 // tile x_min, y_min, x_max, y_max (max exclusive)
};

// ---- Per-view constants (uniform buffer, std140) -----------------------------------------
struct GpuView {
  vec4 w2c_row0;         // rows of world_to_camera's upper 3x4 (rotation | translation)
  vec4 w2c_row1;
  vec4 w2c_row2;
  vec4 camera_centre;    // xyz = -R^T t
  vec4 intrinsics;       // fx, fy, cx, cy
  vec4 limits;           // lim_x, lim_y (frustum clamp), mesh margin, unused
  vec4 clear_colour;     // rgb background without a mesh
  uvec4 size;            // width, height, tiles_x, tiles_y
  uvec4 frame;           // unused, display frame, highlight count, unused
};

// A (tile, slot) pair whose slot is this names no splat; the blend skips it (splat_emit.comp).
GAUSS_CONST(uint, SPLAT_SENTINEL_SLOT, 0xFFFFFFFFu)

// ---- Counters (per view, uint[SPLAT_COUNTER_WORDS]) -----------------------------------------
GAUSS_CONST(uint, SPLAT_COUNTER_VISIBLE, 0u)       // N: splats touching >= 1 tile
GAUSS_CONST(uint, SPLAT_COUNTER_PAIRS_NEEDED, 1u)  // P: (tile, splat) pairs wanted (saturating)
GAUSS_CONST(uint, SPLAT_COUNTER_PAIRS, 2u)         // min(P, pair capacity): pairs emitted
GAUSS_CONST(uint, SPLAT_ARGS_VISIBLE_ITEMS, 4u)    // VkDispatchIndirectCommand words
GAUSS_CONST(uint, SPLAT_ARGS_VISIBLE_BLOCKS, 8u)
GAUSS_CONST(uint, SPLAT_ARGS_PAIR_ITEMS, 12u)
GAUSS_CONST(uint, SPLAT_ARGS_PAIR_BLOCKS, 16u)
// Radix count and histogram scan: empty when the keys fit one block (the scatter then ranks
// them alone, see sort_radix_scatter.comp).
GAUSS_CONST(uint, SPLAT_ARGS_VISIBLE_COUNT, 20u)
GAUSS_CONST(uint, SPLAT_ARGS_VISIBLE_HIST, 24u)
GAUSS_CONST(uint, SPLAT_ARGS_PAIR_COUNT, 28u)
GAUSS_CONST(uint, SPLAT_ARGS_PAIR_HIST, 32u)
GAUSS_CONST(uint, SPLAT_COUNTER_WORDS, 36u)

// ---- Bindings (each pipeline declares the ones it uses) -----------------------------------
GAUSS_BINDING(SPLAT_BINDING_VIEW, 0u)
GAUSS_BINDING(SPLAT_BINDING_CORE, 1u)
GAUSS_BINDING(SPLAT_BINDING_SH, 2u)
GAUSS_BINDING(SPLAT_BINDING_EDIT, 3u)
GAUSS_BINDING(SPLAT_BINDING_HIGHLIGHT, 4u)
GAUSS_BINDING(SPLAT_BINDING_PROJECTED, 5u)
GAUSS_BINDING(SPLAT_BINDING_TILE_COUNT, 6u)
GAUSS_BINDING(SPLAT_BINDING_OFFSETS, 7u)
GAUSS_BINDING(SPLAT_BINDING_KEYS_IN, 8u)
GAUSS_BINDING(SPLAT_BINDING_VALS_IN, 9u)
GAUSS_BINDING(SPLAT_BINDING_KEYS_OUT, 10u)
GAUSS_BINDING(SPLAT_BINDING_VALS_OUT, 11u)
GAUSS_BINDING(SPLAT_BINDING_HIST, 12u)
GAUSS_BINDING(SPLAT_BINDING_COUNTERS, 13u)
GAUSS_BINDING(SPLAT_BINDING_RANGES, 14u)
GAUSS_BINDING(SPLAT_BINDING_OUTPUT, 15u)
GAUSS_BINDING(SPLAT_BINDING_MESH_COLOUR, 16u)
GAUSS_BINDING(SPLAT_BINDING_MESH_DEPTH, 17u)
GAUSS_BINDING(SPLAT_BINDING_TILE_DEPTH, 18u)
GAUSS_BINDING(SPLAT_BINDING_SH_HIGH, 19u)
// Projected splats of slot chunks 1..3 (chunk 0 is SPLAT_BINDING_PROJECTED).
GAUSS_BINDING(SPLAT_BINDING_PROJECTED_1, 20u)
GAUSS_BINDING(SPLAT_BINDING_PROJECTED_2, 21u)
GAUSS_BINDING(SPLAT_BINDING_PROJECTED_3, 22u)

// ---- Specialization constant ids ------------------------------------------------------------
GAUSS_CONST(uint, SPLAT_SPEC_SH_DEGREE, 0u)   // scene SH degree 0..3 (0: SH rest never read)
GAUSS_CONST(uint, SPLAT_SPEC_TINT, 1u)        // highlight / edit tint active
GAUSS_CONST(uint, SPLAT_SPEC_MESH, 2u)        // mesh layer present
GAUSS_CONST(uint, SPLAT_SPEC_SH_STRIDE, 3u)   // floats per slot of the bands 1-2 SH buffer
GAUSS_CONST(uint, SPLAT_SPEC_EXACT_CULL, 4u)  // bin only into tiles alpha >= 1/255 can reach
GAUSS_CONST(uint, SPLAT_SPEC_BALLOT_WORDS, 5u)  // splat_blend.comp: ceil(max subgroup size / 32), 1..4
GAUSS_CONST(uint, SPLAT_SPEC_SLOT_CHUNKS, 6u)   // emit / blend: projected slot chunks, 1..SPLAT_MAX_SLOT_CHUNKS
GAUSS_CONST(uint, SPLAT_SPEC_SLOT_CHUNK_SHIFT, 7u)  // emit / blend: log2(slots per chunk) when chunks > 1
GAUSS_CONST(uint, SPLAT_SPEC_SCAN_MODE, 0u)   // splat_scan.comp: SPLAT_SCAN_*
GAUSS_CONST(uint, SPLAT_SCAN_VISIBLE, 0u)     // flags tile_count[i] > 0 over the slots
GAUSS_CONST(uint, SPLAT_SCAN_PAIRS, 1u)       // tile_count[vals[i]] over the visible list
GAUSS_CONST(uint, SPLAT_SCAN_HIST, 2u)        // radix histogram, in place
// splat_scan_gpu.comp: which step of the reduce-then-scan (no workgroup waits on another:
// Vulkan promises no forward progress between workgroups, so each step is a dispatch).
GAUSS_CONST(uint, SPLAT_SPEC_SCAN_PHASE, 1u)
GAUSS_CONST(uint, SPLAT_SCAN_PHASE_REDUCE, 0u)  // block sums -> hist[block]
GAUSS_CONST(uint, SPLAT_SCAN_PHASE_SPINE, 1u)   // one workgroup: scan of the block sums (or of hist)
GAUSS_CONST(uint, SPLAT_SCAN_PHASE_DOWN, 2u)    // each block rescanned from its scanned sum
// sort_radix_*_gpu.comp and splat_scan_gpu.comp: the digit width (4 or 8 bits), and the
// scatter's shared rows (SPLAT_WORKGROUP / the smallest subgroup the device may use).
GAUSS_CONST(uint, SORT_SPEC_RADIX_BITS, 8u)
GAUSS_CONST(uint, SORT_SPEC_ROWS, 9u)
// sort_radix_scatter_gpu.comp: the scatter sums its digits' block counts itself (no
// offsets pass), for sorts whose keys are known on the CPU to need at most
// SORT_FUSED_OFFSETS_MAX_BLOCKS blocks (the depth sort: the high-water mark bounds them).
GAUSS_CONST(uint, SORT_SPEC_FUSED_OFFSETS, 10u)
GAUSS_CONST(uint, SORT_FUSED_OFFSETS_MAX_BLOCKS, 64u)

// ---- Push constants ---------------------------------------------------------------------------
// One struct for every compute kernel; each reads the fields it documents.
struct GpuSplatPush {
  uint item_count;    // preprocess / compact / visible scan: high-water mark
  uint count_index;   // radix passes and the histogram scan: counter holding the key count
  uint shift;         // radix pass: first key bit of the digit
  uint pair_capacity; // pair scan / emit: pairs the key buffers hold
  uint first_slot;    // preprocess / compact: slot of the bound chunk's first element
};

// Mesh pass push constants (vertex shader).
struct GpuMeshPush {
  vec4 w2c_row0;
  vec4 w2c_row1;
  vec4 w2c_row2;
  vec4 intrinsics;  // fx, fy, cx, cy
  vec4 viewport;    // width, height, near, far
};

GAUSS_SHARED_END

GAUSS_STATIC_ASSERT(sizeof(gauss::gpu::GpuSplatCore) == 64, "GpuSplatCore must be 64 bytes (std430)");
GAUSS_STATIC_ASSERT(sizeof(gauss::gpu::GpuProjected) == 64, "GpuProjected must be 64 bytes (std430)");
GAUSS_STATIC_ASSERT(sizeof(gauss::gpu::GpuView) == 144, "GpuView must be 144 bytes (std140)");
GAUSS_STATIC_ASSERT(sizeof(gauss::gpu::GpuSplatPush) == 20, "GpuSplatPush must be 20 bytes");
GAUSS_STATIC_ASSERT(sizeof(gauss::gpu::GpuMeshPush) == 80, "GpuMeshPush must be 80 bytes");

#endif  // GAUSS_SHADERS_SHARED_SPLAT_LAYOUT_H
