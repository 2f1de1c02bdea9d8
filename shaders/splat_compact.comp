#version 460
// Compaction, one thread per slot below the high-water mark: every drawn slot writes its
// depth key and slot index at its exclusive-scan offset, so the visible list is in slot
// order (the stable depth sort that follows then breaks depth ties by slot).
// The key is the float32 view depth's bit pattern: depths here are > 0.2, and positive
// IEEE floats order like their bits as unsigned integers.
// One dispatch per slot chunk, as preprocess: the projected binding holds that chunk only.
#extension GL_GOOGLE_include_directive : require

#include "splat_common.glsl"

layout(local_size_x = SPLAT_WORKGROUP) in;

layout(std430, binding = SPLAT_BINDING_PROJECTED) readonly buffer ProjBuf { GpuProjected projected[]; };
layout(std430, binding = SPLAT_BINDING_TILE_COUNT) readonly buffer TileCountBuf { uint tile_count[]; };
layout(std430, binding = SPLAT_BINDING_OFFSETS) readonly buffer OffsetsBuf { uint offsets[]; };
layout(std430, binding = SPLAT_BINDING_KEYS_OUT) writeonly buffer KeysBuf { uint keys_out[]; };
layout(std430, binding = SPLAT_BINDING_VALS_OUT) writeonly buffer ValsBuf { uint vals_out[]; };
layout(push_constant) uniform Push { GpuSplatPush pc; };

void main() {
  const uint in_chunk = gl_GlobalInvocationID.x;
  if (in_chunk >= pc.item_count) return;
  const uint slot = pc.first_slot + in_chunk;
  if (tile_count[slot] == 0u) return;
  const uint at = offsets[slot];
  keys_out[at] = floatBitsToUint(projected[in_chunk].centre_depth_opacity.z);
  vals_out[at] = slot;
}
