#version 460
// Per-tile maximum of the mesh view depth (metres; +inf where any pixel has no
// triangle), one 16x16 workgroup per tile, reduced in shared memory. Preprocess and emit
// skip a tile for a splat lying deeper than this + margin: every fragment there would be
// cut by the per-pixel test anyway, so the image cannot change.
#extension GL_GOOGLE_include_directive : require

#define SPLAT_USE_VIEW
#include "splat_common.glsl"

layout(local_size_x = SPLAT_TILE, local_size_y = SPLAT_TILE) in;

layout(binding = SPLAT_BINDING_MESH_DEPTH) uniform sampler2D mesh_depth;
layout(std430, binding = SPLAT_BINDING_TILE_DEPTH) writeonly buffer TileDepthBuf { float tile_max_depth[]; };

shared float s_max[SPLAT_WORKGROUP];

void main() {
  const uvec2 pix = gl_WorkGroupID.xy * SPLAT_TILE + gl_LocalInvocationID.xy;
  const uint lid = gl_LocalInvocationIndex;
  float depth = 0.0;  // pixels outside the image do not count
  if (pix.x < view.size.x && pix.y < view.size.y) {
    const float stored = texelFetch(mesh_depth, ivec2(pix), 0).r;
    depth = stored < 1.0 ? stored * SPLAT_MESH_DEPTH_SCALE : 1.0 / 0.0;
  }
  s_max[lid] = depth;
  barrier();
  for (uint stride = SPLAT_WORKGROUP / 2u; stride > 0u; stride /= 2u) {
    if (lid < stride) s_max[lid] = max(s_max[lid], s_max[lid + stride]);
    barrier();
  }
  if (lid == 0u) tile_max_depth[gl_WorkGroupID.y * view.size.z + gl_WorkGroupID.x] = s_max[0];
}
