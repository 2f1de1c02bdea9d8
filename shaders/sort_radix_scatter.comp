#version 460
// Radix sort pass 2/2: stable scatter of one 4-bit digit. Thread t of block b owns keys
// [b*SORT_BLOCK + t*SORT_ITEMS, +SORT_ITEMS). Its output position for a key with digit d
// = scanned hist[d][b] (keys of smaller digits everywhere + digit d in earlier blocks)
// + keys with digit d of threads t' < t in this block (shared-memory scan of per-thread
// counts) + keys with digit d earlier in its own run. Every term follows input order,
// so the pass is stable; nothing depends on the subgroup size. With a single block the
// count pass and histogram scan are not dispatched (a small scene's frame is mostly fixed
// cost per dispatch): the first term is then the block's own keys of smaller digits.
#extension GL_GOOGLE_include_directive : require

#include "splat_common.glsl"

layout(local_size_x = SPLAT_WORKGROUP) in;

layout(std430, binding = SPLAT_BINDING_KEYS_IN) readonly buffer KeysInBuf { uint keys_in[]; };
layout(std430, binding = SPLAT_BINDING_VALS_IN) readonly buffer ValsInBuf { uint vals_in[]; };
layout(std430, binding = SPLAT_BINDING_KEYS_OUT) writeonly buffer KeysOutBuf { uint keys_out[]; };
layout(std430, binding = SPLAT_BINDING_VALS_OUT) writeonly buffer ValsOutBuf { uint vals_out[]; };
layout(std430, binding = SPLAT_BINDING_HIST) readonly buffer HistBuf { uint hist[]; };
layout(std430, binding = SPLAT_BINDING_COUNTERS) readonly buffer CounterBuf { uint counters[]; };
layout(push_constant) uniform Push { GpuSplatPush pc; };

// 16 digits x 256 threads of counts (16 KiB), scanned per digit in 16 segments of 16.
shared uint s_count[SORT_BINS * SPLAT_WORKGROUP];
shared uint s_segment[SORT_BINS * 16u];
shared uint s_total[SORT_BINS];  // keys of each digit in the block

void main() {
  const uint n = counters[pc.count_index];
  const uint blocks = (n + SORT_BLOCK - 1u) / SORT_BLOCK;
  const uint block = linear_group_id();
  if (block >= blocks) return;  // uniform over the workgroup
  const uint lid = gl_LocalInvocationID.x;
  const uint base = block * SORT_BLOCK + lid * SORT_ITEMS;
  const uint end = min(n, base + SORT_ITEMS);

  uint offset[SORT_BINS];
  for (uint d = 0u; d < SORT_BINS; ++d) offset[d] = 0u;
  for (uint i = base; i < end; ++i) ++offset[(keys_in[i] >> pc.shift) & (SORT_BINS - 1u)];
  for (uint d = 0u; d < SORT_BINS; ++d) s_count[d * SPLAT_WORKGROUP + lid] = offset[d];
  barrier();
  {  // thread (digit, segment) = (lid / 16, lid % 16): exclusive scan of its 16 counts
    const uint row = (lid / 16u) * SPLAT_WORKGROUP + (lid % 16u) * 16u;
    uint run = 0u;
    for (uint j = 0u; j < 16u; ++j) {
      const uint v = s_count[row + j];
      s_count[row + j] = run;
      run += v;
    }
    s_segment[lid] = run;
  }
  barrier();
  if (lid < SORT_BINS) {  // exclusive scan of the 16 segment totals of digit lid
    uint run = 0u;
    for (uint j = 0u; j < 16u; ++j) {
      const uint v = s_segment[lid * 16u + j];
      s_segment[lid * 16u + j] = run;
      run += v;
    }
    s_total[lid] = run;
  }
  barrier();
  uint smaller = 0u;  // single block: keys of smaller digits
  for (uint d = 0u; d < SORT_BINS; ++d) {
    const uint before = blocks == 1u ? smaller : hist[d * blocks + block];
    offset[d] = before + s_segment[d * 16u + lid / 16u] + s_count[d * SPLAT_WORKGROUP + lid];
    smaller += s_total[d];
  }
  for (uint i = base; i < end; ++i) {
    const uint key = keys_in[i];
    const uint d = (key >> pc.shift) & (SORT_BINS - 1u);
    const uint at = offset[d]++;
    keys_out[at] = key;
    vals_out[at] = vals_in[i];
  }
}
