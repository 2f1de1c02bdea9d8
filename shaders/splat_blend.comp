#version 460
// Blend, one workgroup per 16x16 screen tile (splat_math.h "Per pixel"). The tile is split
// into four 8x8 quadrants; each quadrant has 8 invocations, each blending one column of 8
// pixels, so every staged splat read from shared memory serves 8 pixels.
// The tile's run of splats (depth order) is staged through shared memory in batches of
// 256. While staging, each splat is tested against each quadrant with the exact-culling
// bound (rect_reachable, the test that bins pairs into tiles): a splat whose alpha cannot
// reach 1/255 anywhere in a quadrant would change none of its pixels, so it is left out
// of that quadrant's list. The lists keep depth order, so every pixel blends exactly the
// splats it did before, in the same order: the image is unchanged. Invocations of one
// quadrant loop over its list only; on a CPU device, whose SIMD lanes are consecutive
// invocations, that skips work a per-lane branch would still execute.
// Measured on lavapipe (box 100k@640x360, blend GPU ms): one list per tile, 16x2
// invocations of 8 pixels each, ~100 ms; quadrant lists: see docs/DESIGN.md.
// The tile stops reading once every pixel in it is done (transmittance stop or outside
// the image). Output: RGBA8 packed per pixel, rounded with to_unorm8.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require

#define SPLAT_USE_VIEW
#include "splat_common.glsl"

layout(local_size_x = SPLAT_BLEND_THREADS) in;
layout(constant_id = SPLAT_SPEC_MESH) const bool MESH = false;

layout(std430, binding = SPLAT_BINDING_PROJECTED) readonly buffer ProjBuf { GpuProjected projected[]; };
layout(std430, binding = SPLAT_BINDING_VALS_IN) readonly buffer ValsBuf { uint vals[]; };
layout(std430, binding = SPLAT_BINDING_RANGES) readonly buffer RangesBuf { uvec2 ranges[]; };
layout(std430, binding = SPLAT_BINDING_OUTPUT) writeonly buffer OutBuf { uint out_pixels[]; };
layout(rgba8, binding = SPLAT_BINDING_MESH_COLOUR) uniform readonly image2D mesh_colour;
layout(binding = SPLAT_BINDING_MESH_DEPTH) uniform sampler2D mesh_depth;

const uint QUAD = SPLAT_BLEND_QUAD;          // quadrant edge = pixels per invocation
const uint BATCH = SPLAT_WORKGROUP;          // splats staged per batch
const uint STAGED = BATCH / SPLAT_BLEND_THREADS;  // consecutive splats staged per invocation

shared vec4 s_cdo[BATCH];     // u, v, depth, opacity
shared vec4 s_conic[BATCH];
shared vec4 s_colour[BATCH];
shared uint s_list[4u * BATCH];             // per quadrant: batch indices reaching it, in order
shared uint s_counts[SPLAT_BLEND_THREADS];  // per invocation: its staged splats per quadrant, 4 x 8 bits
shared uint s_done;                         // pixels of the tile that are finished

uint to_unorm8(float x) {
  if (!(x > 0.0)) return 0u;  // also NaN
  if (x >= 1.0) return 255u;
  return uint(floor(x * 255.0 + 0.5));
}

void main() {
  const uvec2 tile = gl_WorkGroupID.xy;
  const uint lid = gl_LocalInvocationIndex;
  const uint quad = lid / QUAD;
  const uvec2 origin = tile * SPLAT_TILE + uvec2(quad & 1u, quad >> 1u) * QUAD;
  const uint x = origin.x + lid % QUAD;
  const uvec2 range = ranges[tile.y * view.size.z + tile.x];
  const float px = float(x) + 0.5;

  float py[QUAD];
  bool inside[QUAD];
  bool done[QUAD];
  vec3 background[QUAD];
  float cut[QUAD];
  vec3 C[QUAD];
  float T[QUAD];
  uint outside = 0u;
  [[unroll]] for (uint k = 0u; k < QUAD; ++k) {
    const uint y = origin.y + k;
    py[k] = float(y) + 0.5;
    inside[k] = x < view.size.x && y < view.size.y;
    done[k] = !inside[k];
    outside += done[k] ? 1u : 0u;
    background[k] = view.clear_colour.rgb;
    cut[k] = 1.0 / 0.0;  // +inf: nothing to cut against
    if (MESH && inside[k]) {
      background[k] = imageLoad(mesh_colour, ivec2(x, y)).rgb;
      const float stored = texelFetch(mesh_depth, ivec2(x, y), 0).r;
      if (stored < 1.0) cut[k] = stored * SPLAT_MESH_DEPTH_SCALE + view.limits.z;
    }
    C[k] = vec3(0.0);
    T[k] = 1.0;
  }

  if (lid == 0u) s_done = 0u;
  barrier();
  if (outside > 0u) atomicAdd(s_done, outside);

  // Control flow note: the loops below branch on divergent values only inside `if`s, never
  // through break/continue, so the loop counters stay uniform within a quadrant.
  for (uint base = range.x; base < range.y; base += BATCH) {
    barrier();  // the previous batch is fully processed; s_done is stable until the next barrier
    if (s_done == SPLAT_TILE * SPLAT_TILE) break;  // uniform: every thread reads the same value
    // Stage splats [lid * STAGED, +STAGED) of the batch; reach: 4 quadrant bits per splat.
    uint reach = 0u, counts = 0u;
    [[unroll]] for (uint i = 0u; i < STAGED; ++i) {
      const uint l = lid * STAGED + i;
      const uint idx = base + l;
      if (idx < range.y) {
        const GpuProjected pr = projected[vals[idx]];
        s_cdo[l] = pr.centre_depth_opacity;
        s_conic[l] = pr.conic;
        s_colour[l] = pr.colour;
        const float q_max = exact_cull_qmax(pr.centre_depth_opacity.w);
        [[unroll]] for (uint q = 0u; q < 4u; ++q) {
          const vec2 p0 = vec2(tile * SPLAT_TILE + uvec2(q & 1u, q >> 1u) * QUAD) + 0.5;
          if (rect_reachable(pr.conic.xyz, pr.centre_depth_opacity.xy, q_max, p0.x, p0.x + float(QUAD - 1u), p0.y,
                             p0.y + float(QUAD - 1u))) {
            reach |= 1u << (4u * i + q);
            counts += 1u << (8u * q);
          }
        }
      }
    }
    s_counts[lid] = counts;
    barrier();
    // Exclusive prefix of the counts over earlier invocations (per quadrant byte: at most
    // STAGED * 31 = 248, no carry), and this invocation's quadrant total (up to 256).
    uint prefix = 0u, count = 0u;
    for (uint t = 0u; t < SPLAT_BLEND_THREADS; ++t) {
      const uint v = s_counts[t];
      if (t < lid) prefix += v;
      count += (v >> (8u * quad)) & 0xFFu;
    }
    uint at[4];  // unpacked: the last invocation's offsets can reach 256
    [[unroll]] for (uint q = 0u; q < 4u; ++q) at[q] = q * BATCH + ((prefix >> (8u * q)) & 0xFFu);
    [[unroll]] for (uint i = 0u; i < STAGED; ++i) {
      [[unroll]] for (uint q = 0u; q < 4u; ++q) {
        if ((reach & (1u << (4u * i + q))) != 0u) s_list[at[q]++] = lid * STAGED + i;
      }
    }
    barrier();
    for (uint j = 0u; j < count; ++j) {
      const uint l = s_list[quad * BATCH + j];
      const vec4 cdo = s_cdo[l];
      const vec3 conic = s_conic[l].xyz;
      const vec3 colour = s_colour[l].rgb;
      const float dx = cdo.x - px;
      [[unroll]] for (uint k = 0u; k < QUAD; ++k) {
        if (!done[k]) {
          const float dy = cdo.y - py[k];
          const float power = -0.5 * (conic.x * dx * dx + conic.z * dy * dy) - conic.y * dx * dy;
          // power > 0 or (mesh) deeper than the cut -> this splat adds nothing here.
          if (power <= 0.0 && (!MESH || cdo.z <= cut[k])) {
            const float alpha = min(SPLAT_ALPHA_MAX, cdo.w * exp(power));
            if (alpha >= SPLAT_ALPHA_MIN) {
              const float test_t = T[k] * (1.0 - alpha);
              if (test_t < SPLAT_T_STOP) {
                done[k] = true;  // this splat is not blended; the pixel is finished
                atomicAdd(s_done, 1u);
              } else {
                C[k] += colour * alpha * T[k];
                T[k] = test_t;
              }
            }
          }
        }
      }
    }
  }
  [[unroll]] for (uint k = 0u; k < QUAD; ++k) {
    if (inside[k]) {
      const vec3 final_colour = C[k] + T[k] * background[k];
      const uint y = origin.y + k;
      out_pixels[y * view.size.x + x] = to_unorm8(final_colour.r) | (to_unorm8(final_colour.g) << 8u) |
                                        (to_unorm8(final_colour.b) << 16u) | (255u << 24u);
    }
  }
}
