#version 460
// Between the GPU shapes' radix count and scatter (blocks > 1 only): workgroup d scans
// digit d's row of the histogram, hist[d * blocks + b] over the blocks b, in place
// (exclusive: the keys of digit d in the blocks before b), and writes the row's total to
// hist[BINS * blocks + d]. The scatter adds the totals of the smaller digits itself.
// One workgroup per digit instead of one workgroup over the whole histogram: with 8-bit
// digits the histogram holds 256 words per block (1M keys: 65536 words, which one
// workgroup would walk in 256 barrier-separated steps); a row is a few hundred words.
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require

#include "splat_common.glsl"
#include "splat_subgroup.glsl"

layout(local_size_x = SPLAT_WORKGROUP) in;
layout(constant_id = SORT_SPEC_RADIX_BITS) const uint RADIX_BITS = 4u;
const uint BINS = 1u << RADIX_BITS;

layout(std430, binding = SPLAT_BINDING_HIST) buffer HistBuf { uint hist[]; };
layout(std430, binding = SPLAT_BINDING_COUNTERS) readonly buffer CounterBuf { uint counters[]; };
layout(push_constant) uniform Push { GpuSplatPush pc; };

void main() {
  const uint n = counters[pc.count_index];
  const uint blocks = (n + SORT_BLOCK_GPU - 1u) / SORT_BLOCK_GPU;
  const uint d = linear_group_id();
  if (d >= BINS) return;  // uniform over the workgroup
  const uint row = d * blocks;
  uint run = 0u;  // counts of one digit never exceed n < 2^32: no saturation reached
  for (uint base = 0u; base < blocks; base += SPLAT_WORKGROUP) {
    const uint b = base + wg_index();
    const uint v = b < blocks ? hist[row + b] : 0u;
    uint total;
    const uint before = wg_exclusive_scan(v, total);
    if (b < blocks) hist[row + b] = run + before;
    run += total;
  }
  if (wg_index() == 0u) hist[BINS * blocks + d] = run;
}
