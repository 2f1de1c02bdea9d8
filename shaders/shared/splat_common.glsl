// GLSL helpers shared by the splat compute kernels (GLSL only; the layout is in
// splat_layout.h). Define SPLAT_USE_VIEW before including to get the view uniform block.
#ifndef GAUSS_SHADERS_SHARED_SPLAT_COMMON_GLSL
#define GAUSS_SHADERS_SHARED_SPLAT_COMMON_GLSL

#include "splat_layout.h"

#ifdef SPLAT_USE_VIEW
layout(std140, binding = SPLAT_BINDING_VIEW) uniform ViewBlock { GpuView view; };
#endif

// Linear workgroup index of a dispatch that may wrap into y (see SPLAT_DISPATCH_ROW).
uint linear_group_id() {
  return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
}

// Saturating add: totals of (tile, splat) pairs can exceed 2^32 for absurd inputs; a
// saturated total still compares as "more than the pair capacity".
uint sat_add(uint a, uint b) {
  return (a > 0xFFFFFFFFu - b) ? 0xFFFFFFFFu : a + b;
}

// Exact culling. A fragment at offset d from the centre is blended only if
// opacity * exp(-q/2) >= 1/255 with q = A dx^2 + 2 B dx dy + C dy^2, i.e.
// q <= q_max = 2 ln(255 opacity). rect_reachable() says whether some pixel sample of a
// rectangle can pass (tile_reachable: a screen tile's pixel centres, clipped to the image),
// from the minimum of q over the rectangle: a lower bound of q at every sample, so skipping a tile
// for which it returns false never changes the image. The slack (a relative 1e-4 of
// the terms plus 0.02 in q, i.e. 1 % in alpha) covers float rounding of this test and
// of the blend's own evaluation. A non positive-definite conic (only possible through
// float rounding) disables the culling for that splat.
float exact_cull_qmax(float opacity) {
  return 2.0 * log(255.0 * opacity) + 0.02;
}

float conic_q(vec3 conic, float dx, float dy) {
  return conic.x * dx * dx + 2.0 * conic.y * dx * dy + conic.z * dy * dy;
}

float conic_q_abs(vec3 conic, float dx, float dy) {
  return conic.x * dx * dx + 2.0 * abs(conic.y * dx * dy) + conic.z * dy * dy;
}

// Minimum of q over [x0, x1] x [y0, y1] along the edge x = xe (y free in [y0, y1]).
float edge_min_x(vec3 conic, float xe, float y0, float y1, inout float q_abs) {
  const float y = clamp(-conic.y * xe / conic.z, y0, y1);
  q_abs = conic_q_abs(conic, xe, y);
  return conic_q(conic, xe, y);
}
float edge_min_y(vec3 conic, float ye, float x0, float x1, inout float q_abs) {
  const float x = clamp(-conic.y * ye / conic.x, x0, x1);
  q_abs = conic_q_abs(conic, x, ye);
  return conic_q(conic, x, ye);
}

// Whether some pixel centre of [px0, px1] x [py0, py1] (pixel-centre coordinates) can pass.
bool rect_reachable(vec3 conic, vec2 centre, float q_max, float px0, float px1, float py0, float py1) {
  if (!(conic.x > 0.0 && conic.z > 0.0 && conic.x * conic.z - conic.y * conic.y > 0.0)) return true;
  const float x0 = px0 - centre.x, x1 = px1 - centre.x;
  const float y0 = py0 - centre.y, y1 = py1 - centre.y;
  if (x0 <= 0.0 && x1 >= 0.0 && y0 <= 0.0 && y1 >= 0.0) return true;  // centre inside
  float a0 = 0.0, a1 = 0.0, a2 = 0.0, a3 = 0.0;
  const float q0 = edge_min_x(conic, x0, y0, y1, a0);
  const float q1 = edge_min_x(conic, x1, y0, y1, a1);
  const float q2 = edge_min_y(conic, y0, x0, x1, a2);
  const float q3 = edge_min_y(conic, y1, x0, x1, a3);
  const float q = min(min(q0, q1), min(q2, q3));
  const float q_abs = max(max(a0, a1), max(a2, a3));
  return q <= q_max + 1e-4 * q_abs;
}

// rect_reachable over the pixels of screen tile (tx, ty), clipped to the image.
bool tile_reachable(vec3 conic, vec2 centre, float q_max, uint tx, uint ty, uint width, uint height) {
  return rect_reachable(conic, centre, q_max, float(tx * SPLAT_TILE) + 0.5,
                        float(min(tx * SPLAT_TILE + SPLAT_TILE, width) - 1u) + 0.5, float(ty * SPLAT_TILE) + 0.5,
                        float(min(ty * SPLAT_TILE + SPLAT_TILE, height) - 1u) + 0.5);
}

#endif  // GAUSS_SHADERS_SHARED_SPLAT_COMMON_GLSL
