// Subgroup building blocks of the GPU pass shapes (splat_scan_gpu.comp,
// sort_radix_count_gpu.comp, sort_radix_scatter_gpu.comp). GLSL only; include after
// splat_common.glsl. The including shader enables GL_KHR_shader_subgroup_basic, _arithmetic
// and _ballot (the operations the renderer already requires of a device for the blend).
//
// Subgroup-size agnostic by construction: nothing assumes a size, only that a workgroup of
// SPLAT_WORKGROUP (256) invocations is made of gl_NumSubgroups full subgroups, which holds
// for every power-of-two size 4..128 (256 is a multiple of each; Vulkan subgroup sizes are
// powers of two), and which the pipelines require where the device has computeFullSubgroups
// (splat_pipelines.cpp). Invocations are numbered by (subgroup, lane), never by
// gl_LocalInvocationIndex, because Vulkan does not say which local ids share a subgroup:
// wg_index() is the order every scan and rank follows.
#ifndef GAUSS_SHADERS_SHARED_SPLAT_SUBGROUP_GLSL
#define GAUSS_SHADERS_SHARED_SPLAT_SUBGROUP_GLSL

// This invocation's place in the workgroup's scan order, 0 .. SPLAT_WORKGROUP - 1.
uint wg_index() {
  return gl_SubgroupID * gl_SubgroupSize + gl_SubgroupInvocationID;
}

// Saturating subgroup sums. A 32-bit subgroupAdd could wrap (the pair scan's totals may
// exceed 2^32 for absurd inputs; the CPU shapes saturate, see sat_add), so the high and low
// 16 bits are summed apart: each half sums at most 128 x 65535 < 2^23, exactly.
uint sat_join(uint hi, uint lo) {
  return hi > 0xFFFFu ? 0xFFFFFFFFu : sat_add(hi << 16, lo);
}
uint subgroup_sat_add(uint v) {
  return sat_join(subgroupAdd(v >> 16), subgroupAdd(v & 0xFFFFu));
}
uint subgroup_sat_exclusive(uint v) {
  return sat_join(subgroupExclusiveAdd(v >> 16), subgroupExclusiveAdd(v & 0xFFFFu));
}

shared uint s_wg_sub[SPLAT_MAX_SUBGROUPS];

// Exclusive saturating prefix of v over the workgroup in wg_index() order; `total` gets the
// workgroup's saturated sum. Call from uniform control flow (two barriers). Each invocation
// adds its earlier subgroups' sums itself (at most 63 shared reads of one broadcast word;
// 7 with 32-wide subgroups) instead of a third barrier-separated step.
uint wg_exclusive_scan(uint v, out uint total) {
  const uint within = subgroup_sat_exclusive(v);
  const uint sub_total = subgroup_sat_add(v);
  if (subgroupElect()) s_wg_sub[gl_SubgroupID] = sub_total;
  barrier();
  uint before = 0u;
  total = 0u;
  for (uint s = 0u; s < gl_NumSubgroups; ++s) {
    const uint t = s_wg_sub[s];
    if (s == gl_SubgroupID) before = total;
    total = sat_add(total, t);
  }
  barrier();  // s_wg_sub is rewritten by the next call
  return sat_add(before, within);
}

// The lanes of this subgroup holding the same radix digit d (of `bits` bits) as this lane,
// among the lanes with `valid` set, as a ballot: one ballot per digit bit instead of one
// per digit value. Call from uniform control flow.
uvec4 digit_peers(uint d, bool valid, uint bits) {
  uvec4 peers = subgroupBallot(valid);
  for (uint b = 0u; b < bits; ++b) {
    const bool bit = ((d >> b) & 1u) != 0u;
    const uvec4 ones = subgroupBallot(bit);
    peers &= bit ? ones : ~ones;
  }
  return peers;
}

#endif  // GAUSS_SHADERS_SHARED_SPLAT_SUBGROUP_GLSL
