#version 460
// Emit (tile, slot) pairs, one thread per visible splat in depth order: splat k writes
// its tile_count pairs from its scanned offset, tiles in row-major order, with the same
// per-tile tests as splat_preprocess.comp. The tile sort that follows is stable, so each
// tile's run stays in depth order. Pairs at or past the pair capacity are dropped: those
// are the farthest splats' (the offsets follow depth order), deterministically, and the
// frame reports the overflow (counters[PAIRS_NEEDED] > capacity).
// A splat never writes outside its own range: should the repeated test pass fewer tiles
// than preprocess counted (it cannot with identical arithmetic, but two shaders may be
// compiled differently), the remaining entries name no splat (SPLAT_SENTINEL_SLOT) in the
// last tile, which the blend skips. Tile ids thus stay below tiles_x * tiles_y, and the
// tile sort needs no extra bit for a sentinel id (1024x1024: 12 bits, 3 passes, not 4).
#extension GL_GOOGLE_include_directive : require

#define SPLAT_USE_VIEW
#include "splat_common.glsl"
#include "splat_projected.glsl"

layout(local_size_x = SPLAT_WORKGROUP) in;
layout(constant_id = SPLAT_SPEC_MESH) const bool MESH = false;
layout(constant_id = SPLAT_SPEC_EXACT_CULL) const bool EXACT_CULL = true;

layout(std430, binding = SPLAT_BINDING_TILE_COUNT) readonly buffer TileCountBuf { uint tile_count[]; };
layout(std430, binding = SPLAT_BINDING_OFFSETS) readonly buffer OffsetsBuf { uint offsets[]; };
layout(std430, binding = SPLAT_BINDING_VALS_IN) readonly buffer ValsInBuf { uint vals_in[]; };
layout(std430, binding = SPLAT_BINDING_KEYS_OUT) writeonly buffer KeysOutBuf { uint keys_out[]; };
layout(std430, binding = SPLAT_BINDING_VALS_OUT) writeonly buffer ValsOutBuf { uint vals_out[]; };
layout(std430, binding = SPLAT_BINDING_COUNTERS) readonly buffer CounterBuf { uint counters[]; };
layout(std430, binding = SPLAT_BINDING_TILE_DEPTH) readonly buffer TileDepthBuf { float tile_max_depth[]; };
layout(push_constant) uniform Push { GpuSplatPush pc; };

void main() {
  const uint k = linear_group_id() * SPLAT_WORKGROUP + gl_LocalInvocationID.x;
  if (k >= counters[SPLAT_COUNTER_VISIBLE]) return;
  const uint slot = vals_in[k];
  const uint count = tile_count[slot];
  uint at = offsets[k];
  if (at >= pc.pair_capacity) return;
  const uint end = min(pc.pair_capacity, sat_add(at, count));

  const GpuProjected pr = load_projected(slot);
  const vec2 centre = pr.centre_depth_opacity.xy;
  const float depth = pr.centre_depth_opacity.z;
  const vec3 conic = pr.conic.xyz;
  const float q_max = exact_cull_qmax(pr.centre_depth_opacity.w);
  const uvec4 rect = pr.rect;
  for (uint ty = rect.y; ty < rect.w && at < end; ++ty) {
    for (uint tx = rect.x; tx < rect.z && at < end; ++tx) {
      if (MESH && depth > tile_max_depth[ty * view.size.z + tx] + view.limits.z) continue;
      if (EXACT_CULL && !tile_reachable(conic, centre, q_max, tx, ty, view.size.x, view.size.y)) continue;
      keys_out[at] = ty * view.size.z + tx;
      vals_out[at] = slot;
      ++at;
    }
  }
  for (; at < end; ++at) {
    keys_out[at] = view.size.z * view.size.w - 1u;
    vals_out[at] = SPLAT_SENTINEL_SLOT;
  }
}
