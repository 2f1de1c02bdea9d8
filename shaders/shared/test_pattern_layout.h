// Layout of shaders/test_pattern.comp, the compute shader of the first golden test
// (tests/render/test_vk_golden_pattern.cpp, which also recomputes the pattern on the
// CPU). The pattern per pixel (x, y) inside a WORKGROUP x WORKGROUP tile:
//   R = (x * r_mul + y * 3 + seed) & 255           r_mul: specialization constant
//   G = uint(f * 40) & 255, f = (x * (1/64)) * 0.7 + (y * 0.37)^2 * 0.01, float32,
//       each operation rounded separately (GLSL `precise`: no fused multiply-add)
//   B = (tile_sum + 3 * tile_count) & 255          subgroupAdd inside each subgroup,
//       tile_sum = sum of ((x ^ y) + seed) and      then shared-memory atomics across
//       tile_count = number of pixels of the tile   subgroups: independent of the
//       that lie inside the image                   subgroup size
//   A = 255 for even tiles (tile_x + tile_y), 191 for odd ones
// and, per tile, tile_sums[tile_y * tiles_x + tile_x] = tile_sum (a storage buffer;
// tiles past the buffer's end are not written).
#ifndef GAUSS_SHADERS_SHARED_TEST_PATTERN_LAYOUT_H
#define GAUSS_SHADERS_SHARED_TEST_PATTERN_LAYOUT_H

#include "glsl_cpp.h"

GAUSS_SHARED_BEGIN

// Workgroup edge: 16 x 16 = 256 invocations, several subgroups at any subgroup size.
GAUSS_CONST(uint, TEST_PATTERN_WORKGROUP, 16u)
// The output: an rgba8 storage image (OffscreenTarget colour, GENERAL layout).
GAUSS_BINDING(TEST_PATTERN_BINDING_IMAGE, 0u)
// Per-tile sums: a storage buffer of uint.
GAUSS_BINDING(TEST_PATTERN_BINDING_TILE_SUMS, 1u)
// Specialization constant id of r_mul.
GAUSS_CONST(uint, TEST_PATTERN_SPEC_R_MUL, 0u)

struct TestPatternPush {
  uint width;   // image size; invocations outside it write nothing
  uint height;
  uint seed;
  uint pad0;
};

GAUSS_SHARED_END

GAUSS_STATIC_ASSERT(sizeof(gauss::gpu::TestPatternPush) == 16, "TestPatternPush must be 16 bytes");

#endif  // GAUSS_SHADERS_SHARED_TEST_PATTERN_LAYOUT_H
