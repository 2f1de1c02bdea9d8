#version 460
// Blend, one 16x16 workgroup per screen tile, one thread per pixel (splat_math.h "Per
// pixel"). The tile's run of splats (depth order) is staged through shared memory in
// batches of 256 (each splat loaded once for the whole tile), and the tile stops reading
// as soon as every pixel in it is done (transmittance stop or outside the image).
// Output: RGBA8 packed per pixel into the output buffer, rounded with to_unorm8.
#extension GL_GOOGLE_include_directive : require

#define SPLAT_USE_VIEW
#include "splat_common.glsl"

layout(local_size_x = SPLAT_TILE, local_size_y = SPLAT_TILE) in;
layout(constant_id = SPLAT_SPEC_MESH) const bool MESH = false;

layout(std430, binding = SPLAT_BINDING_PROJECTED) readonly buffer ProjBuf { GpuProjected projected[]; };
layout(std430, binding = SPLAT_BINDING_VALS_IN) readonly buffer ValsBuf { uint vals[]; };
layout(std430, binding = SPLAT_BINDING_RANGES) readonly buffer RangesBuf { uvec2 ranges[]; };
layout(std430, binding = SPLAT_BINDING_OUTPUT) writeonly buffer OutBuf { uint out_pixels[]; };
layout(rgba8, binding = SPLAT_BINDING_MESH_COLOUR) uniform readonly image2D mesh_colour;
layout(binding = SPLAT_BINDING_MESH_DEPTH) uniform sampler2D mesh_depth;

shared vec4 s_cdo[SPLAT_WORKGROUP];     // u, v, depth, opacity
shared vec4 s_conic[SPLAT_WORKGROUP];
shared vec4 s_colour[SPLAT_WORKGROUP];
shared uint s_done;

uint to_unorm8(float x) {
  if (!(x > 0.0)) return 0u;  // also NaN
  if (x >= 1.0) return 255u;
  return uint(floor(x * 255.0 + 0.5));
}

void main() {
  const uvec2 tile = gl_WorkGroupID.xy;
  const uvec2 pix = tile * SPLAT_TILE + gl_LocalInvocationID.xy;
  const uint lid = gl_LocalInvocationIndex;
  const bool inside = pix.x < view.size.x && pix.y < view.size.y;
  const uvec2 range = ranges[tile.y * view.size.z + tile.x];
  const float px = float(pix.x) + 0.5, py = float(pix.y) + 0.5;

  vec3 background = view.clear_colour.rgb;
  float cut = 1.0 / 0.0;  // +inf: nothing to cut against
  if (MESH && inside) {
    background = imageLoad(mesh_colour, ivec2(pix)).rgb;
    const float stored = texelFetch(mesh_depth, ivec2(pix), 0).r;
    if (stored < 1.0) cut = stored * SPLAT_MESH_DEPTH_SCALE + view.limits.z;
  }

  if (lid == 0u) s_done = 0u;
  barrier();
  bool done = !inside;
  if (done) atomicAdd(s_done, 1u);
  vec3 C = vec3(0.0);
  float T = 1.0;

  for (uint base = range.x; base < range.y; base += SPLAT_WORKGROUP) {
    barrier();  // the previous batch is fully processed; s_done is stable until the next barrier
    if (s_done == SPLAT_WORKGROUP) break;  // uniform: every thread reads the same value
    const uint idx = base + lid;
    if (idx < range.y) {
      const GpuProjected pr = projected[vals[idx]];
      s_cdo[lid] = pr.centre_depth_opacity;
      s_conic[lid] = pr.conic;
      s_colour[lid] = pr.colour;
    }
    barrier();
    if (done) continue;
    const uint count = min(SPLAT_WORKGROUP, range.y - base);
    for (uint j = 0u; j < count; ++j) {
      const vec4 cdo = s_cdo[j];
      const vec3 conic = s_conic[j].xyz;
      const float dx = cdo.x - px, dy = cdo.y - py;
      const float power = -0.5 * (conic.x * dx * dx + conic.z * dy * dy) - conic.y * dx * dy;
      if (power > 0.0) continue;
      if (MESH && cdo.z > cut) continue;
      const float alpha = min(SPLAT_ALPHA_MAX, cdo.w * exp(power));
      if (alpha < SPLAT_ALPHA_MIN) continue;
      const float test_t = T * (1.0 - alpha);
      if (test_t < SPLAT_T_STOP) {
        done = true;
        atomicAdd(s_done, 1u);
        break;
      }
      C += s_colour[j].rgb * alpha * T;
      T = test_t;
    }
  }
  if (!inside) return;
  const vec3 final_colour = C + T * background;
  out_pixels[pix.y * view.size.x + pix.x] = to_unorm8(final_colour.r) | (to_unorm8(final_colour.g) << 8u) |
                                            (to_unorm8(final_colour.b) << 16u) | (255u << 24u);
}
