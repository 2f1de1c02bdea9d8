// Layout of shaders/depth_projection.comp: the renderer's depth target, copied into a buffer
// of floats, rewritten in place as the depth an OpenXR compositor expects of a depth layer
// (XR_KHR_composition_layer_depth): a perspective projection's [0, 1] depth for the planes
// near and far, d = far * (z - near) / (z * (far - near)), where z = stored * scale is the
// view depth the mesh pass stored; stored >= 1 (nothing drawn: splats write no depth) stays
// 1 (the far plane), z <= near becomes 0 and z >= far 1.
#ifndef GAUSS_SHADERS_SHARED_DEPTH_PROJECTION_LAYOUT_H
#define GAUSS_SHADERS_SHARED_DEPTH_PROJECTION_LAYOUT_H

#include "glsl_cpp.h"

GAUSS_SHARED_BEGIN

GAUSS_CONST(uint, DEPTH_PROJECTION_WORKGROUP, 64u)
// The depth values: a storage buffer of float, rewritten in place.
GAUSS_BINDING(DEPTH_PROJECTION_BINDING_DEPTH, 0u)

struct DepthProjectionPush {
  uint count;   // values in the buffer
  float scale;  // view depth per stored unit (SPLAT_MESH_DEPTH_SCALE)
  float near_z;
  float far_z;
};

GAUSS_SHARED_END

GAUSS_STATIC_ASSERT(sizeof(gauss::gpu::DepthProjectionPush) == 16, "DepthProjectionPush must be 16 bytes");

#endif
