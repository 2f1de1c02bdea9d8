#version 460
// Radix sort pass 1/2: per-block histogram of one 4-bit digit. Block b (SORT_BLOCK keys)
// writes hist[digit * blocks + b], the digit-major layout whose exclusive scan
// (splat_scan.comp, SPLAT_SCAN_HIST) gives every (digit, block) its output offset.
// Shared-memory integer atomics only count (exact, order-independent); no subgroup ops.
#extension GL_GOOGLE_include_directive : require

#include "splat_common.glsl"

layout(local_size_x = SPLAT_WORKGROUP) in;

layout(std430, binding = SPLAT_BINDING_KEYS_IN) readonly buffer KeysBuf { uint keys_in[]; };
layout(std430, binding = SPLAT_BINDING_HIST) writeonly buffer HistBuf { uint hist[]; };
layout(std430, binding = SPLAT_BINDING_COUNTERS) readonly buffer CounterBuf { uint counters[]; };
layout(push_constant) uniform Push { GpuSplatPush pc; };

shared uint s_hist[SORT_BINS];

void main() {
  const uint n = counters[pc.count_index];
  const uint blocks = (n + SORT_BLOCK - 1u) / SORT_BLOCK;
  const uint block = linear_group_id();
  if (block >= blocks) return;  // uniform over the workgroup
  const uint lid = gl_LocalInvocationID.x;
  if (lid < SORT_BINS) s_hist[lid] = 0u;
  barrier();
  const uint base = block * SORT_BLOCK + lid * SORT_ITEMS;
  for (uint k = 0u; k < SORT_ITEMS; ++k) {
    const uint i = base + k;
    if (i < n) atomicAdd(s_hist[(keys_in[i] >> pc.shift) & (SORT_BINS - 1u)], 1u);
  }
  barrier();
  if (lid < SORT_BINS) hist[lid * blocks + block] = s_hist[lid];
}
