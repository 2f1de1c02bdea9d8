#version 460
// Tile ranges, one thread per emitted pair of the tile-sorted list: a pair whose tile
// differs from its predecessor's starts that tile's run, one that differs from its
// successor's ends it. ranges[] is cleared to (0, 0) before, so untouched tiles are empty.
// Every tile id is below tiles_x * tiles_y (see splat_emit.comp); a larger one is ignored.
#extension GL_GOOGLE_include_directive : require

#define SPLAT_USE_VIEW
#include "splat_common.glsl"

layout(local_size_x = SPLAT_WORKGROUP) in;

layout(std430, binding = SPLAT_BINDING_KEYS_IN) readonly buffer KeysBuf { uint keys[]; };
layout(std430, binding = SPLAT_BINDING_RANGES) buffer RangesBuf { uvec2 ranges[]; };
layout(std430, binding = SPLAT_BINDING_COUNTERS) readonly buffer CounterBuf { uint counters[]; };

void main() {
  const uint i = linear_group_id() * SPLAT_WORKGROUP + gl_LocalInvocationID.x;
  const uint n = counters[SPLAT_COUNTER_PAIRS];
  if (i >= n) return;
  const uint tile = keys[i];
  if (tile >= view.size.z * view.size.w) return;
  if (i == 0u || keys[i - 1u] != tile) ranges[tile].x = i;
  if (i + 1u == n || keys[i + 1u] != tile) ranges[tile].y = i + 1u;
}
