#version 460
// Blend, GPU shape (splat_pass_shapes.cpp): one workgroup of 256 invocations per 16x16
// screen tile, one pixel per invocation (invocation i: column i % 16, row i / 16). The
// tile's run of splats (depth order) goes through shared memory in batches of 256: each
// invocation loads one splat of the batch (consecutive invocations read consecutive
// entries of the sorted list), then every invocation blends the whole batch into its
// pixel, in order. A batch load is the only global read a splat costs its tile, instead of
// one per subgroup as in splat_blend.comp; the pixel work is the same arithmetic in the
// same order, so the image is byte-identical to the CPU shape's (render tests run both).
//
// Why not on lavapipe: there, a non-constant load costs a loop over the SIMD lanes and a
// divergent branch still runs, so culling each splat per subgroup before any pixel work
// won (box 100k@640x360 blend 102 ms batched vs 50 ms culled; docs/DESIGN.md). A GPU
// wants many invocations per tile to hide load latency and coalesced loads: 256 per tile
// instead of 32, each with one pixel instead of eight.
//
// The workgroup stops once every pixel is done (transmittance stop or outside the image):
// each subgroup with a live pixel adds one to a shared count before the batch's barrier,
// and a batch that sees zero ends the loop for all invocations alike. Two counts
// alternate so that resetting one never races with reading the other.
// A sentinel entry (SPLAT_SENTINEL_SLOT, past a pair overflow) is stored as a zero-opacity
// splat at the origin: alpha 0 is below SPLAT_ALPHA_MIN, so it blends nothing, exactly as
// the CPU shape skips it.
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_vote : require

#define SPLAT_USE_VIEW
#include "splat_common.glsl"
#include "splat_projected.glsl"

const uint BATCH = SPLAT_TILE * SPLAT_TILE;
layout(local_size_x = BATCH) in;
layout(constant_id = SPLAT_SPEC_MESH) const bool MESH = false;

layout(std430, binding = SPLAT_BINDING_VALS_IN) readonly buffer ValsBuf { uint vals[]; };
layout(std430, binding = SPLAT_BINDING_RANGES) readonly buffer RangesBuf { uvec2 ranges[]; };
layout(std430, binding = SPLAT_BINDING_OUTPUT) writeonly buffer OutBuf { uint out_pixels[]; };
layout(rgba8, binding = SPLAT_BINDING_MESH_COLOUR) uniform readonly image2D mesh_colour;
layout(binding = SPLAT_BINDING_MESH_DEPTH) uniform sampler2D mesh_depth;

shared vec4 s_cdo[BATCH];     // centre u, v, depth, opacity
shared vec4 s_conic[BATCH];   // A, B, C, unused
shared vec4 s_colour[BATCH];  // rgb, unused
shared uint s_live[2];        // subgroups with a live pixel, per batch parity

uint to_unorm8(float x) {
  if (!(x > 0.0)) return 0u;  // also NaN
  if (x >= 1.0) return 255u;
  return uint(floor(x * 255.0 + 0.5));
}

void main() {
  const uvec2 tile = gl_WorkGroupID.xy;
  const uint lid = gl_LocalInvocationIndex;
  const uint x = tile.x * SPLAT_TILE + lid % SPLAT_TILE;
  const uint y = tile.y * SPLAT_TILE + lid / SPLAT_TILE;
  const uvec2 range = ranges[tile.y * view.size.z + tile.x];
  const float px = float(x) + 0.5, py = float(y) + 0.5;

  const bool inside = x < view.size.x && y < view.size.y;
  bool done = !inside;
  vec3 background = view.clear_colour.rgb;
  float cut = 1.0 / 0.0;  // +inf: nothing to cut against
  if (MESH && inside) {
    background = imageLoad(mesh_colour, ivec2(x, y)).rgb;
    const float stored = texelFetch(mesh_depth, ivec2(x, y), 0).r;
    if (stored < 1.0) cut = stored * SPLAT_MESH_DEPTH_SCALE + view.limits.z;
  }
  vec3 C = vec3(0.0);
  float T = 1.0;

  if (lid < 2u) s_live[lid] = 0u;
  barrier();
  uint parity = 0u;
  for (uint base = range.x; base < range.y; base += BATCH, parity ^= 1u) {
    if (subgroupAny(!done) && subgroupElect()) atomicAdd(s_live[parity], 1u);
    if (lid == 0u) s_live[parity ^ 1u] = 0u;  // read last batch, before its closing barrier
    const uint idx = base + lid;
    if (idx < range.y) {
      const uint slot = vals[idx];
      if (slot != SPLAT_SENTINEL_SLOT) {
        const GpuProjected pr = load_projected(slot);
        s_cdo[lid] = pr.centre_depth_opacity;
        s_conic[lid] = pr.conic;
        s_colour[lid] = pr.colour;
      } else {
        s_cdo[lid] = vec4(0.0);
        s_conic[lid] = vec4(0.0);
        s_colour[lid] = vec4(0.0);
      }
    }
    barrier();
    if (s_live[parity] == 0u) break;  // the same value for every invocation
    const uint n = min(BATCH, range.y - base);
    for (uint j = 0u; j < n && !done; ++j) {
      const vec4 cdo = s_cdo[j];
      const vec3 conic = s_conic[j].xyz;
      const float dx = cdo.x - px;
      const float dy = cdo.y - py;
      const float power = -0.5 * (conic.x * dx * dx + conic.z * dy * dy) - conic.y * dx * dy;
      // power > 0 or (mesh) deeper than the cut -> this splat adds nothing here.
      if (power <= 0.0 && (!MESH || cdo.z <= cut)) {
        const float alpha = min(SPLAT_ALPHA_MAX, cdo.w * exp(power));
        if (alpha >= SPLAT_ALPHA_MIN) {
          const float test_t = T * (1.0 - alpha);
          if (test_t < SPLAT_T_STOP) {
            done = true;  // this splat is not blended; the pixel is finished
          } else {
            C += s_colour[j].rgb * alpha * T;
            T = test_t;
          }
        }
      }
    }
    barrier();  // the next batch overwrites the shared splats
  }
  if (inside) {
    const vec3 final_colour = C + T * background;
    out_pixels[y * view.size.x + x] = to_unorm8(final_colour.r) | (to_unorm8(final_colour.g) << 8u) |
                                      (to_unorm8(final_colour.b) << 16u) | (255u << 24u);
  }
}
