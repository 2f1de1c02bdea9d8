#version 460
// Writes the known test pattern described in shared/test_pattern_layout.h. Exercises
// integer and float arithmetic, a specialization constant, push constants, a storage
// image, shared memory and subgroup arithmetic whose result must not depend on the
// subgroup size (lavapipe: 4, 8 or 16 with LP_NATIVE_VECTOR_WIDTH 128, 256, 512).
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require

#include "test_pattern_layout.h"

layout(local_size_x = TEST_PATTERN_WORKGROUP, local_size_y = TEST_PATTERN_WORKGROUP) in;
layout(constant_id = TEST_PATTERN_SPEC_R_MUL) const uint r_mul = 1u;
layout(rgba8, binding = TEST_PATTERN_BINDING_IMAGE) uniform writeonly image2D out_image;
layout(std430, binding = TEST_PATTERN_BINDING_TILE_SUMS) writeonly buffer TileSums { uint tile_sums[]; };
layout(push_constant) uniform Push { TestPatternPush pc; };

shared uint s_tile_sum;
shared uint s_tile_count;

void main() {
  const uvec2 p = gl_GlobalInvocationID.xy;
  const bool inside = p.x < pc.width && p.y < pc.height;

  if (gl_LocalInvocationIndex == 0u) {
    s_tile_sum = 0u;
    s_tile_count = 0u;
  }
  barrier();
  // Every invocation takes part (no early return before the barriers).
  const uint sub_sum = subgroupAdd(inside ? ((p.x ^ p.y) + pc.seed) : 0u);
  const uint sub_count = subgroupAdd(inside ? 1u : 0u);
  if (subgroupElect()) {
    atomicAdd(s_tile_sum, sub_sum);
    atomicAdd(s_tile_count, sub_count);
  }
  barrier();
  if (gl_LocalInvocationIndex == 0u) {
    const uint tile = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (tile < uint(tile_sums.length())) tile_sums[tile] = s_tile_sum;
  }
  if (!inside) return;

  const uint r = (p.x * r_mul + p.y * 3u + pc.seed) & 255u;
  precise float fx = float(p.x) * (1.0 / 64.0);
  precise float fy = float(p.y) * 0.37;
  precise float f = fx * 0.7 + (fy * fy) * 0.01;
  const uint g = uint(f * 40.0) & 255u;
  const uint b = (s_tile_sum + 3u * s_tile_count) & 255u;
  const uint a = (((gl_WorkGroupID.x + gl_WorkGroupID.y) & 1u) == 0u) ? 255u : 191u;
  imageStore(out_image, ivec2(p), vec4(uvec4(r, g, b, a)) / 255.0);
}
