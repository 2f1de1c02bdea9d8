#version 460
// Blend, one workgroup per 16x16 screen tile (splat_math.h "Per pixel"). The workgroup is
// 16 x SPLAT_BLEND_ROWS invocations and each invocation blends SPLAT_BLEND_PIXELS pixels
// of one column (rows ly, ly + ROWS, ...): every staged splat is read once from shared
// memory and used for several pixels. Measured on lavapipe (box 100k@640x360, CPU time
// per frame): 1 pixel/thread 590 ms, 4 pixels 276 ms, 8 pixels 227 ms, 16 pixels 214 ms;
// 8 (32 threads per tile) keeps workgroups wide enough for GPUs' 32/64-wide waves.
// The tile's run of splats (depth order) is staged through shared memory in batches of
// 256, and the tile stops reading once every pixel in it is done (transmittance stop or
// outside the image). Output: RGBA8 packed per pixel, rounded with to_unorm8.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require

#define SPLAT_USE_VIEW
#include "splat_common.glsl"

layout(local_size_x = SPLAT_TILE, local_size_y = SPLAT_BLEND_ROWS) in;
layout(constant_id = SPLAT_SPEC_MESH) const bool MESH = false;

layout(std430, binding = SPLAT_BINDING_PROJECTED) readonly buffer ProjBuf { GpuProjected projected[]; };
layout(std430, binding = SPLAT_BINDING_VALS_IN) readonly buffer ValsBuf { uint vals[]; };
layout(std430, binding = SPLAT_BINDING_RANGES) readonly buffer RangesBuf { uvec2 ranges[]; };
layout(std430, binding = SPLAT_BINDING_OUTPUT) writeonly buffer OutBuf { uint out_pixels[]; };
layout(rgba8, binding = SPLAT_BINDING_MESH_COLOUR) uniform readonly image2D mesh_colour;
layout(binding = SPLAT_BINDING_MESH_DEPTH) uniform sampler2D mesh_depth;

const uint THREADS = SPLAT_TILE * SPLAT_BLEND_ROWS;
const uint BATCH = SPLAT_WORKGROUP;  // splats staged per batch (BATCH / THREADS loads each)

shared vec4 s_cdo[BATCH];     // u, v, depth, opacity
shared vec4 s_conic[BATCH];
shared vec4 s_colour[BATCH];
shared uint s_done;           // pixels of the tile that are finished

uint to_unorm8(float x) {
  if (!(x > 0.0)) return 0u;  // also NaN
  if (x >= 1.0) return 255u;
  return uint(floor(x * 255.0 + 0.5));
}

void main() {
  const uvec2 tile = gl_WorkGroupID.xy;
  const uint lid = gl_LocalInvocationIndex;
  const uint x = tile.x * SPLAT_TILE + gl_LocalInvocationID.x;
  const uvec2 range = ranges[tile.y * view.size.z + tile.x];
  const float px = float(x) + 0.5;

  float py[SPLAT_BLEND_PIXELS];
  bool inside[SPLAT_BLEND_PIXELS];
  bool done[SPLAT_BLEND_PIXELS];
  vec3 background[SPLAT_BLEND_PIXELS];
  float cut[SPLAT_BLEND_PIXELS];
  vec3 C[SPLAT_BLEND_PIXELS];
  float T[SPLAT_BLEND_PIXELS];
  uint outside = 0u;
  [[unroll]] for (uint k = 0u; k < SPLAT_BLEND_PIXELS; ++k) {
    const uint y = tile.y * SPLAT_TILE + gl_LocalInvocationID.y + k * SPLAT_BLEND_ROWS;
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
  // through break/continue, so the loop counters stay uniform.
  for (uint base = range.x; base < range.y; base += BATCH) {
    barrier();  // the previous batch is fully processed; s_done is stable until the next barrier
    if (s_done == SPLAT_TILE * SPLAT_TILE) break;  // uniform: every thread reads the same value
    [[unroll]] for (uint l = lid; l < BATCH; l += THREADS) {
      const uint idx = base + l;
      if (idx < range.y) {
        const GpuProjected pr = projected[vals[idx]];
        s_cdo[l] = pr.centre_depth_opacity;
        s_conic[l] = pr.conic;
        s_colour[l] = pr.colour;
      }
    }
    barrier();
    const uint count = min(BATCH, range.y - base);
    for (uint j = 0u; j < count; ++j) {
      const vec4 cdo = s_cdo[j];
      const vec3 conic = s_conic[j].xyz;
      const vec3 colour = s_colour[j].rgb;
      const float dx = cdo.x - px;
      [[unroll]] for (uint k = 0u; k < SPLAT_BLEND_PIXELS; ++k) {
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
  [[unroll]] for (uint k = 0u; k < SPLAT_BLEND_PIXELS; ++k) {
    if (inside[k]) {
      const vec3 final_colour = C[k] + T[k] * background[k];
      const uint y = tile.y * SPLAT_TILE + gl_LocalInvocationID.y + k * SPLAT_BLEND_ROWS;
      out_pixels[y * view.size.x + x] = to_unorm8(final_colour.r) | (to_unorm8(final_colour.g) << 8u) |
                                        (to_unorm8(final_colour.b) << 16u) | (255u << 24u);
    }
  }
}
