#version 460
// Exclusive prefix sum in ONE workgroup (dispatch 1x1x1) over any length: thread t
// owns a contiguous chunk, sums it, the 256 chunk sums are scanned in shared memory,
// then every thread writes its chunk's prefixes. Work is O(n) with two reads per value;
// no subgroup operation is used (correct at any subgroup size). Totals saturate at
// 2^32 - 1 (see sat_add). Thread 0 also writes the totals and indirect dispatch sizes.
//   SPLAT_SCAN_VISIBLE: n = high-water mark, value = tile_count[i] > 0, out offsets[i];
//                       total -> counters[VISIBLE] and the visible dispatch arguments.
//   SPLAT_SCAN_PAIRS:   n = counters[VISIBLE], value = tile_count[vals[i]] (vals: slots in
//                       depth order), out offsets[i]; total -> counters[PAIRS_NEEDED],
//                       min(total, pair capacity) -> counters[PAIRS], pair arguments.
//   SPLAT_SCAN_HIST:    n = 16 * blocks(counters[count_index]), in place on hist (dispatched
//                       only for two blocks or more).
#extension GL_GOOGLE_include_directive : require

#include "splat_common.glsl"

layout(local_size_x = SPLAT_WORKGROUP) in;
layout(constant_id = SPLAT_SPEC_SCAN_MODE) const uint MODE = 0u;

layout(std430, binding = SPLAT_BINDING_TILE_COUNT) readonly buffer TileCountBuf { uint tile_count[]; };
layout(std430, binding = SPLAT_BINDING_VALS_IN) readonly buffer ValsBuf { uint vals[]; };
layout(std430, binding = SPLAT_BINDING_OFFSETS) writeonly buffer OffsetsBuf { uint offsets[]; };
layout(std430, binding = SPLAT_BINDING_HIST) buffer HistBuf { uint hist[]; };
layout(std430, binding = SPLAT_BINDING_COUNTERS) buffer CounterBuf { uint counters[]; };
layout(push_constant) uniform Push { GpuSplatPush pc; };

shared uint s_sums[SPLAT_WORKGROUP];

uint item_count() {
  if (MODE == SPLAT_SCAN_VISIBLE) return pc.item_count;
  if (MODE == SPLAT_SCAN_PAIRS) return counters[SPLAT_COUNTER_VISIBLE];
  return SORT_BINS * ((counters[pc.count_index] + SORT_BLOCK - 1u) / SORT_BLOCK);
}

uint value(uint i) {
  if (MODE == SPLAT_SCAN_VISIBLE) return tile_count[i] > 0u ? 1u : 0u;
  if (MODE == SPLAT_SCAN_PAIRS) return tile_count[vals[i]];
  return hist[i];
}

void store(uint i, uint prefix) {
  if (MODE == SPLAT_SCAN_HIST) hist[i] = prefix;
  else offsets[i] = prefix;
}

void write_args(uint at, uint groups) {
  counters[at] = min(groups, SPLAT_DISPATCH_ROW);
  counters[at + 1u] = max(1u, (groups + SPLAT_DISPATCH_ROW - 1u) / SPLAT_DISPATCH_ROW);
  counters[at + 2u] = 1u;
}

// A radix pass's dispatches: the scatter gets every block; the count and the histogram
// scan get nothing when there is a single block (the scatter then needs no histogram).
void write_sort_args(uint keys, uint blocks_at, uint count_at, uint hist_at) {
  const uint blocks = (keys + SORT_BLOCK - 1u) / SORT_BLOCK;
  write_args(blocks_at, blocks);
  write_args(count_at, blocks > 1u ? blocks : 0u);
  write_args(hist_at, blocks > 1u ? 1u : 0u);
}

void main() {
  const uint lid = gl_LocalInvocationID.x;
  const uint n = item_count();
  const uint per = (n + SPLAT_WORKGROUP - 1u) / SPLAT_WORKGROUP;
  const uint begin = min(n, lid * per);
  const uint end = min(n, begin + per);

  uint sum = 0u;
  for (uint i = begin; i < end; ++i) sum = sat_add(sum, value(i));
  s_sums[lid] = sum;
  barrier();
  if (lid == 0u) {
    uint run = 0u;
    for (uint k = 0u; k < SPLAT_WORKGROUP; ++k) {
      const uint v = s_sums[k];
      s_sums[k] = run;
      run = sat_add(run, v);
    }
    if (MODE == SPLAT_SCAN_VISIBLE) {
      counters[SPLAT_COUNTER_VISIBLE] = run;
      write_args(SPLAT_ARGS_VISIBLE_ITEMS, (run + SPLAT_WORKGROUP - 1u) / SPLAT_WORKGROUP);
      write_sort_args(run, SPLAT_ARGS_VISIBLE_BLOCKS, SPLAT_ARGS_VISIBLE_COUNT, SPLAT_ARGS_VISIBLE_HIST);
    } else if (MODE == SPLAT_SCAN_PAIRS) {
      const uint used = min(run, pc.pair_capacity);
      counters[SPLAT_COUNTER_PAIRS_NEEDED] = run;
      counters[SPLAT_COUNTER_PAIRS] = used;
      write_args(SPLAT_ARGS_PAIR_ITEMS, (used + SPLAT_WORKGROUP - 1u) / SPLAT_WORKGROUP);
      write_sort_args(used, SPLAT_ARGS_PAIR_BLOCKS, SPLAT_ARGS_PAIR_COUNT, SPLAT_ARGS_PAIR_HIST);
    }
  }
  barrier();
  uint run = s_sums[lid];
  for (uint i = begin; i < end; ++i) {
    const uint v = value(i);
    store(i, run);
    run = sat_add(run, v);
  }
}
