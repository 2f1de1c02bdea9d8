// Reading projected splats by slot across slot chunks (splat_layout.h "Slot chunks"), for
// the passes that visit slots in depth or tile order (emit, blend). Include after
// splat_common.glsl; declares the projected bindings, so the shader must not.
//
// Without descriptor indexing an array of bindings cannot be indexed by a lane's slot, so
// each chunk has a binding of its own and load_projected() branches on the chunk. With
// SLOT_CHUNKS == 1 the branch is specialised away and the load is the unsplit one.
#ifndef GAUSS_SHADERS_SHARED_SPLAT_PROJECTED_GLSL
#define GAUSS_SHADERS_SHARED_SPLAT_PROJECTED_GLSL

layout(constant_id = SPLAT_SPEC_SLOT_CHUNKS) const uint SLOT_CHUNKS = 1u;
layout(constant_id = SPLAT_SPEC_SLOT_CHUNK_SHIFT) const uint SLOT_CHUNK_SHIFT = 31u;

layout(std430, binding = SPLAT_BINDING_PROJECTED) readonly buffer ProjBuf0 { GpuProjected projected0[]; };
layout(std430, binding = SPLAT_BINDING_PROJECTED_1) readonly buffer ProjBuf1 { GpuProjected projected1[]; };
layout(std430, binding = SPLAT_BINDING_PROJECTED_2) readonly buffer ProjBuf2 { GpuProjected projected2[]; };
layout(std430, binding = SPLAT_BINDING_PROJECTED_3) readonly buffer ProjBuf3 { GpuProjected projected3[]; };

GpuProjected load_projected(uint slot) {
  if (SLOT_CHUNKS == 1u) return projected0[slot];
  const uint chunk = slot >> SLOT_CHUNK_SHIFT;
  const uint i = slot & ((1u << SLOT_CHUNK_SHIFT) - 1u);
  if (chunk == 0u) return projected0[i];
  if (chunk == 1u) return projected1[i];
  if (chunk == 2u) return projected2[i];
  return projected3[i];
}

#endif  // GAUSS_SHADERS_SHARED_SPLAT_PROJECTED_GLSL
