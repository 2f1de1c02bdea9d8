#version 460
// The GPU shape of splat_scan.comp's VISIBLE and PAIRS modes (same results, same counters;
// the radix arguments are those of the GPU radix passes): an exclusive, saturating prefix
// sum as reduce-then-scan over blocks of SORT_BLOCK_GPU values, three dispatches with a
// barrier between them:
//   REDUCE  workgroup b sums block b -> hist[b]
//   SPINE   one workgroup scans hist in place and writes the totals and indirect
//           arguments as splat_scan.comp does
//   DOWN    workgroup b rescans block b from hist[b] -> offsets
// (The radix histogram is scanned per digit by sort_radix_offsets_gpu.comp instead.)
// splat_scan.comp runs in one workgroup whose threads each walk a contiguous run, which a
// GPU spends on one SM with uncoalesced loads (1M slots: 1.7 ms on an H100). Here every
// loop takes one value per invocation per iteration, so consecutive invocations read
// consecutive words, and a workgroup never waits on another (no forward-progress
// assumption). hist is free while a scan runs (the radix passes own it only inside a
// sort), and holds the block sums: blocks(n) <= 16 * blocks(sort keys) words.
//   VISIBLE: n = high-water mark (push), REDUCE / DOWN dispatched directly.
//   PAIRS:   n = counters[VISIBLE], REDUCE / DOWN dispatched with the visible radix-block
//            arguments (the radix block equals the scan block, SORT_BLOCK_GPU).
// REDUCE and DOWN load all of an invocation's values before using the first (load_block):
// the loads are in flight together, where a load inside DOWN's barrier-separated loop
// waited a full memory latency per iteration (two for PAIRS, whose value is an indirection).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require

#include "splat_common.glsl"
#include "splat_subgroup.glsl"

layout(local_size_x = SPLAT_WORKGROUP) in;
layout(constant_id = SPLAT_SPEC_SCAN_MODE) const uint MODE = 0u;
layout(constant_id = SPLAT_SPEC_SCAN_PHASE) const uint PHASE = 0u;
layout(constant_id = SORT_SPEC_RADIX_BITS) const uint RADIX_BITS = 4u;  // the radix passes' digits

layout(std430, binding = SPLAT_BINDING_TILE_COUNT) readonly buffer TileCountBuf { uint tile_count[]; };
layout(std430, binding = SPLAT_BINDING_VALS_IN) readonly buffer ValsBuf { uint vals[]; };
layout(std430, binding = SPLAT_BINDING_OFFSETS) writeonly buffer OffsetsBuf { uint offsets[]; };
layout(std430, binding = SPLAT_BINDING_HIST) buffer HistBuf { uint hist[]; };
layout(std430, binding = SPLAT_BINDING_COUNTERS) buffer CounterBuf { uint counters[]; };
layout(push_constant) uniform Push { GpuSplatPush pc; };

uint item_count() {
  return MODE == SPLAT_SCAN_VISIBLE ? pc.item_count : counters[SPLAT_COUNTER_VISIBLE];
}

uint value(uint i) {
  if (MODE == SPLAT_SCAN_VISIBLE) return tile_count[i] > 0u ? 1u : 0u;
  return tile_count[vals[i]];
}

void write_args(uint at, uint groups) {
  counters[at] = min(groups, SPLAT_DISPATCH_ROW);
  counters[at + 1u] = max(1u, (groups + SPLAT_DISPATCH_ROW - 1u) / SPLAT_DISPATCH_ROW);
  counters[at + 2u] = 1u;
}

// As splat_scan.comp, with the GPU radix block; the histogram step is one workgroup per
// digit (sort_radix_offsets_gpu.comp). A single block needs neither count nor offsets.
void write_sort_args(uint keys, uint blocks_at, uint count_at, uint hist_at) {
  const uint blocks = (keys + SORT_BLOCK_GPU - 1u) / SORT_BLOCK_GPU;
  write_args(blocks_at, blocks);
  write_args(count_at, blocks > 1u ? blocks : 0u);
  write_args(hist_at, blocks > 1u ? (1u << RADIX_BITS) : 0u);
}

// This invocation's values of the block at `base`, 0 past n.
void load_block(uint base, uint n, out uint v[SORT_ITEMS_GPU]) {
  [[unroll]] for (uint j = 0u; j < SORT_ITEMS_GPU; ++j) {
    const uint i = base + j * SPLAT_WORKGROUP + wg_index();
    v[j] = i < n ? value(i) : 0u;
  }
}

void reduce(uint n) {
  const uint block = linear_group_id();
  const uint base = block * SORT_BLOCK_GPU;
  if (base >= n) return;  // uniform over the workgroup
  // Per invocation at most 16 values below 2^32: summed with saturation, then across the
  // workgroup saturating as well.
  uint v[SORT_ITEMS_GPU];
  load_block(base, n, v);
  uint sum = 0u;
  [[unroll]] for (uint j = 0u; j < SORT_ITEMS_GPU; ++j) sum = sat_add(sum, v[j]);
  uint total;
  wg_exclusive_scan(sum, total);
  if (wg_index() == 0u) hist[block] = total;
}

void spine(uint n) {
  const uint m = (n + SORT_BLOCK_GPU - 1u) / SORT_BLOCK_GPU;  // block sums in hist
  uint run = 0u;
  for (uint base = 0u; base < m; base += SPLAT_WORKGROUP) {
    const uint i = base + wg_index();
    const uint v = i < m ? hist[i] : 0u;
    uint total;
    const uint before = wg_exclusive_scan(v, total);
    if (i < m) hist[i] = sat_add(run, before);
    run = sat_add(run, total);
  }
  if (wg_index() != 0u) return;
  if (MODE == SPLAT_SCAN_VISIBLE) {
    counters[SPLAT_COUNTER_VISIBLE] = run;
    write_args(SPLAT_ARGS_VISIBLE_ITEMS, (run + SPLAT_WORKGROUP - 1u) / SPLAT_WORKGROUP);
    write_sort_args(run, SPLAT_ARGS_VISIBLE_BLOCKS, SPLAT_ARGS_VISIBLE_COUNT, SPLAT_ARGS_VISIBLE_HIST);
  } else {
    const uint used = min(run, pc.pair_capacity);
    counters[SPLAT_COUNTER_PAIRS_NEEDED] = run;
    counters[SPLAT_COUNTER_PAIRS] = used;
    write_args(SPLAT_ARGS_PAIR_ITEMS, (used + SPLAT_WORKGROUP - 1u) / SPLAT_WORKGROUP);
    write_sort_args(used, SPLAT_ARGS_PAIR_BLOCKS, SPLAT_ARGS_PAIR_COUNT, SPLAT_ARGS_PAIR_HIST);
  }
}

void down(uint n) {
  const uint block = linear_group_id();
  const uint base = block * SORT_BLOCK_GPU;
  if (base >= n) return;  // uniform over the workgroup
  uint v[SORT_ITEMS_GPU];
  load_block(base, n, v);
  uint run = hist[block];
  [[unroll]] for (uint j = 0u; j < SORT_ITEMS_GPU; ++j) {
    const uint i = base + j * SPLAT_WORKGROUP + wg_index();
    uint total;
    const uint before = wg_exclusive_scan(v[j], total);
    if (i < n) offsets[i] = sat_add(run, before);
    run = sat_add(run, total);
  }
}

void main() {
  const uint n = item_count();
  if (PHASE == SPLAT_SCAN_PHASE_REDUCE) reduce(n);
  else if (PHASE == SPLAT_SCAN_PHASE_SPINE) spine(n);
  else down(n);
}
