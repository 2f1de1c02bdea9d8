#version 460
// The GPU shape of sort_radix_scatter.comp: a stable scatter of one digit of RADIX_BITS (4
// or 8) bits over blocks of SORT_BLOCK_GPU keys, after sort_radix_count_gpu.comp and, with
// several blocks, sort_radix_offsets_gpu.comp (a single block ranks its own digits and
// needs neither). Subgroup s of the block owns the contiguous run of
// SORT_ITEMS_GPU * gl_SubgroupSize keys after those of subgroups s' < s, and walks it one
// key per lane per iteration, so a subgroup reads consecutive words and writes each
// digit's keys of an iteration to consecutive words. A key's output position is
//   keys of smaller digits in the whole list                    (s_base: scan of the totals)
//   + keys of digit d in the blocks before this one              (offsets row; 0 for one block)
//   + keys of digit d in the runs of subgroups s' < s            (s_off, scanned per digit)
//   + keys of digit d in this subgroup's earlier iterations      (s_off, advanced per iteration)
//   + lanes below it with digit d in this iteration              (ballot rank)
// Every term follows input order, so the pass is stable and the output equals the CPU
// shape's. Subgroups never wait on each other inside an iteration, only at the workgroup
// barriers around the per-digit scan; each s_off row is touched by its own subgroup only,
// in order (subgroup barriers). ROWS (specialised: SPLAT_WORKGROUP / the device's smallest
// subgroup) sizes s_off, ROWS * BINS words: 8-bit digits are chosen only where it fits.
// FUSED_OFFSETS (several blocks, at most SORT_FUSED_OFFSETS_MAX_BLOCKS): no offsets pass
// ran, so each of the first BINS invocations sums its digit's row of block counts itself,
// before this block and in all: on a GPU one pass's dispatch and barrier cost more than
// a few dozen reads of a small, cached row (an H100 barrier: 5 us).
// Every key and value of the run is loaded into registers first (see
// sort_radix_count_gpu.comp: one memory latency instead of one per iteration and loop).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require

#include "splat_common.glsl"
#include "splat_subgroup.glsl"

layout(local_size_x = SPLAT_WORKGROUP) in;
layout(constant_id = SORT_SPEC_RADIX_BITS) const uint RADIX_BITS = 4u;
layout(constant_id = SORT_SPEC_ROWS) const uint ROWS = SPLAT_MAX_SUBGROUPS;
layout(constant_id = SORT_SPEC_FUSED_OFFSETS) const bool FUSED_OFFSETS = false;
const uint BINS = 1u << RADIX_BITS;

layout(std430, binding = SPLAT_BINDING_KEYS_IN) readonly buffer KeysInBuf { uint keys_in[]; };
layout(std430, binding = SPLAT_BINDING_VALS_IN) readonly buffer ValsInBuf { uint vals_in[]; };
layout(std430, binding = SPLAT_BINDING_KEYS_OUT) writeonly buffer KeysOutBuf { uint keys_out[]; };
layout(std430, binding = SPLAT_BINDING_VALS_OUT) writeonly buffer ValsOutBuf { uint vals_out[]; };
layout(std430, binding = SPLAT_BINDING_HIST) readonly buffer HistBuf { uint hist[]; };
layout(std430, binding = SPLAT_BINDING_COUNTERS) readonly buffer CounterBuf { uint counters[]; };
layout(push_constant) uniform Push { GpuSplatPush pc; };

// Row s: per digit, the keys of subgroup s's run, then its next output position.
shared uint s_off[ROWS * BINS];
shared uint s_total[BINS];  // keys of each digit: in the block (one block) or in the list
shared uint s_base[BINS];   // keys of the smaller digits
shared uint s_before[BINS];  // FUSED_OFFSETS: keys of each digit in the blocks before this one

void main() {
  const uint n = counters[pc.count_index];
  const uint blocks = (n + SORT_BLOCK_GPU - 1u) / SORT_BLOCK_GPU;
  const uint block = linear_group_id();
  if (block >= blocks) return;  // uniform over the workgroup
  const uint lid = gl_LocalInvocationIndex;
  const uint sg = gl_SubgroupID;
  const uint lane = gl_SubgroupInvocationID;
  const uint row = sg * BINS;
  const uint run_base = block * SORT_BLOCK_GPU + sg * (SORT_ITEMS_GPU * gl_SubgroupSize);

  uint key[SORT_ITEMS_GPU], val[SORT_ITEMS_GPU];
  [[unroll]] for (uint j = 0u; j < SORT_ITEMS_GPU; ++j) {
    const uint i = run_base + j * gl_SubgroupSize + lane;
    key[j] = i < n ? keys_in[i] : 0u;
    val[j] = i < n ? vals_in[i] : 0u;
  }
  for (uint d = lane; d < BINS; d += gl_SubgroupSize) s_off[row + d] = 0u;
  subgroupMemoryBarrierShared();
  subgroupBarrier();
  [[unroll]] for (uint j = 0u; j < SORT_ITEMS_GPU; ++j) {  // count this subgroup's run per digit
    const bool valid = run_base + j * gl_SubgroupSize + lane < n;
    const uint d = valid ? (key[j] >> pc.shift) & (BINS - 1u) : 0u;
    const uvec4 peers = digit_peers(d, valid, RADIX_BITS);
    if (valid && subgroupBallotBitCount(peers & gl_SubgroupLtMask) == 0u) s_off[row + d] += subgroupBallotBitCount(peers);
    subgroupMemoryBarrierShared();
    subgroupBarrier();
  }
  barrier();
  if (lid < BINS) {  // BINS <= SPLAT_WORKGROUP
    uint total = 0u;
    if (blocks == 1u) {
      for (uint s = 0u; s < gl_NumSubgroups; ++s) total += s_off[s * BINS + lid];
    } else if (FUSED_OFFSETS) {  // the count pass's raw row (blocks <= SORT_FUSED_OFFSETS_MAX_BLOCKS)
      uint before = 0u;
      for (uint b = 0u; b < blocks; ++b) {
        const uint c = hist[lid * blocks + b];
        before += b < block ? c : 0u;
        total += c;
      }
      s_before[lid] = before;
    } else {
      total = hist[BINS * blocks + lid];
    }
    s_total[lid] = total;
  }
  barrier();
  {  // digit bases: an exclusive scan of the totals in digit order (wg_index order)
    const uint d = wg_index();
    uint all;
    const uint before = wg_exclusive_scan(d < BINS ? s_total[d] : 0u, all);
    if (d < BINS) s_base[d] = before;
  }
  barrier();
  if (lid < BINS) {  // digit lid: where each subgroup's keys of it start
    uint run = s_base[lid] + (blocks == 1u ? 0u : FUSED_OFFSETS ? s_before[lid] : hist[lid * blocks + block]);
    for (uint s = 0u; s < gl_NumSubgroups; ++s) {
      const uint v = s_off[s * BINS + lid];
      s_off[s * BINS + lid] = run;
      run += v;
    }
  }
  barrier();
  [[unroll]] for (uint j = 0u; j < SORT_ITEMS_GPU; ++j) {
    const bool valid = run_base + j * gl_SubgroupSize + lane < n;
    const uint d = (key[j] >> pc.shift) & (BINS - 1u);
    const uvec4 peers = digit_peers(d, valid, RADIX_BITS);
    const uint rank = subgroupBallotBitCount(peers & gl_SubgroupLtMask);
    const uint start = s_off[row + d];
    if (valid) {
      keys_out[start + rank] = key[j];
      vals_out[start + rank] = val[j];
    }
    subgroupMemoryBarrierShared();
    subgroupBarrier();  // every lane has read its digit's start before it moves on
    if (valid && rank == 0u) s_off[row + d] = start + subgroupBallotBitCount(peers);
    subgroupMemoryBarrierShared();
    subgroupBarrier();
  }
}
