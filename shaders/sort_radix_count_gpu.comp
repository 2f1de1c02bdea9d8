#version 460
// The GPU shape of sort_radix_count.comp: the digit histogram of each block of
// SORT_BLOCK_GPU keys, hist[digit * blocks + b], for digits of RADIX_BITS (4 or 8) bits.
// Every iteration reads one key per invocation, so consecutive invocations read
// consecutive words; the keys of one digit in a subgroup are counted by ballot and added
// by one lane, instead of one shared atomic per key (a few bins hit by 256 invocations
// serialise on a GPU). Counting is order-independent: exact at any subgroup size.
// All of an invocation's keys are loaded before the first is counted: sixteen loads in
// flight cost one memory latency, where loading in the counting loop cost sixteen (the
// H100 spent 35-40 us per radix pass on such chains whatever the key count).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require

#include "splat_common.glsl"
#include "splat_subgroup.glsl"

layout(local_size_x = SPLAT_WORKGROUP) in;
layout(constant_id = SORT_SPEC_RADIX_BITS) const uint RADIX_BITS = 4u;
const uint BINS = 1u << RADIX_BITS;

layout(std430, binding = SPLAT_BINDING_KEYS_IN) readonly buffer KeysBuf { uint keys_in[]; };
layout(std430, binding = SPLAT_BINDING_HIST) writeonly buffer HistBuf { uint hist[]; };
layout(std430, binding = SPLAT_BINDING_COUNTERS) readonly buffer CounterBuf { uint counters[]; };
layout(push_constant) uniform Push { GpuSplatPush pc; };

shared uint s_hist[BINS];

void main() {
  const uint n = counters[pc.count_index];
  const uint blocks = (n + SORT_BLOCK_GPU - 1u) / SORT_BLOCK_GPU;
  const uint block = linear_group_id();
  if (block >= blocks) return;  // uniform over the workgroup
  const uint lid = gl_LocalInvocationIndex;
  if (lid < BINS) s_hist[lid] = 0u;  // BINS <= SPLAT_WORKGROUP
  barrier();
  const uint base = block * SORT_BLOCK_GPU;
  uint key[SORT_ITEMS_GPU];
  [[unroll]] for (uint j = 0u; j < SORT_ITEMS_GPU; ++j) {
    const uint i = base + j * SPLAT_WORKGROUP + wg_index();
    key[j] = i < n ? keys_in[i] : 0u;
  }
  [[unroll]] for (uint j = 0u; j < SORT_ITEMS_GPU; ++j) {
    const bool valid = base + j * SPLAT_WORKGROUP + wg_index() < n;
    const uint d = valid ? (key[j] >> pc.shift) & (BINS - 1u) : 0u;
    const uvec4 peers = digit_peers(d, valid, RADIX_BITS);
    if (valid && subgroupBallotBitCount(peers & gl_SubgroupLtMask) == 0u)
      atomicAdd(s_hist[d], subgroupBallotBitCount(peers));
  }
  barrier();
  if (lid < BINS) hist[lid * blocks + block] = s_hist[lid];
}
