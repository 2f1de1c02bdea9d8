#version 460
// The renderer's linear depth as a perspective projection's depth (see
// shared/depth_projection_layout.h): one value per invocation, no subgroup operations.
#extension GL_GOOGLE_include_directive : require

#include "depth_projection_layout.h"

layout(local_size_x = DEPTH_PROJECTION_WORKGROUP) in;
layout(std430, binding = DEPTH_PROJECTION_BINDING_DEPTH) buffer Depth { float depth[]; };
layout(push_constant) uniform Push { DepthProjectionPush pc; };

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= pc.count) return;
  const float stored = depth[i];
  if (!(stored < 1.0)) {
    depth[i] = 1.0;
    return;
  }
  const float z = stored * pc.scale;
  const float d = pc.far_z * (z - pc.near_z) / (z * (pc.far_z - pc.near_z));
  depth[i] = z <= pc.near_z ? 0.0 : clamp(d, 0.0, 1.0);
}
