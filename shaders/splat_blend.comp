#version 460
// Blend, one workgroup of 32 invocations per 16x16 screen tile (splat_math.h "Per pixel").
// Invocation i blends one column of 8 pixels: column i % 16, rows 8 * (i / 16) .. +7.
// Each subgroup walks the tile's run of splats (depth order) on its own, in chunks of one
// splat per invocation: every invocation loads one splat and tests it against the
// rectangle of pixels its subgroup covers, with the exact-culling bound (rect_reachable,
// the test that bins pairs into tiles); then the subgroup blends the chunk's splats that
// pass, in order, each broadcast from the invocation that loaded it. A splat that fails
// cannot reach alpha 1/255 at any of the subgroup's pixels, so every pixel blends exactly
// the splats it would blend without the test, in the same order: the image is unchanged.
// The design holds for any subgroup size and shape (the rectangle comes from the
// subgroup's own invocations): lavapipe runs 4, 8 or 16 invocations per subgroup, GPUs
// 32-128 (then one subgroup covers the tile). Why: on lavapipe a divergent branch still
// executes its body, and a memory load costs a loop over the SIMD lanes, so the blend ran
// at the speed of its loads; here each splat is loaded once per subgroup and culled
// before any pixel work (box 100k@640x360 blend: 102 ms with one shared-memory batch per
// tile, 50 ms this way; docs/DESIGN.md).
// A subgroup stops once all of its pixels are done (transmittance stop or outside the
// image). Output: RGBA8 packed per pixel, rounded with to_unorm8.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_vote : require
#extension GL_KHR_shader_subgroup_arithmetic : require

#define SPLAT_USE_VIEW
#include "splat_common.glsl"
#include "splat_projected.glsl"

layout(local_size_x = SPLAT_BLEND_THREADS) in;
layout(constant_id = SPLAT_SPEC_MESH) const bool MESH = false;
// Ballot words that can hold a bit: a constant, so that on lavapipe (one word) the loop
// over them folds away instead of costing a pass per chunk (gl_SubgroupSize is not folded).
layout(constant_id = SPLAT_SPEC_BALLOT_WORDS) const uint BALLOT_WORDS = 1u;

layout(std430, binding = SPLAT_BINDING_VALS_IN) readonly buffer ValsBuf { uint vals[]; };
layout(std430, binding = SPLAT_BINDING_RANGES) readonly buffer RangesBuf { uvec2 ranges[]; };
layout(std430, binding = SPLAT_BINDING_OUTPUT) writeonly buffer OutBuf { uint out_pixels[]; };
layout(rgba8, binding = SPLAT_BINDING_MESH_COLOUR) uniform readonly image2D mesh_colour;
layout(binding = SPLAT_BINDING_MESH_DEPTH) uniform sampler2D mesh_depth;

const uint ROWS = SPLAT_BLEND_PIXELS;  // pixels per invocation, one column

uint to_unorm8(float x) {
  if (!(x > 0.0)) return 0u;  // also NaN
  if (x >= 1.0) return 255u;
  return uint(floor(x * 255.0 + 0.5));
}

void main() {
  const uvec2 tile = gl_WorkGroupID.xy;
  const uint lid = gl_LocalInvocationIndex;
  const uint column = lid % SPLAT_TILE, row0 = (lid / SPLAT_TILE) * ROWS;
  const uint x = tile.x * SPLAT_TILE + column;
  const uvec2 range = ranges[tile.y * view.size.z + tile.x];
  const float px = float(x) + 0.5;

  float py[ROWS];
  bool done[ROWS];
  vec3 background[ROWS];
  float cut[ROWS];
  vec3 C[ROWS];
  float T[ROWS];
  [[unroll]] for (uint k = 0u; k < ROWS; ++k) {
    const uint y = tile.y * SPLAT_TILE + row0 + k;
    py[k] = float(y) + 0.5;
    done[k] = !(x < view.size.x && y < view.size.y);
    background[k] = view.clear_colour.rgb;
    cut[k] = 1.0 / 0.0;  // +inf: nothing to cut against
    if (MESH && !done[k]) {
      background[k] = imageLoad(mesh_colour, ivec2(x, y)).rgb;
      const float stored = texelFetch(mesh_depth, ivec2(x, y), 0).r;
      if (stored < 1.0) cut[k] = stored * SPLAT_MESH_DEPTH_SCALE + view.limits.z;
    }
    C[k] = vec3(0.0);
    T[k] = 1.0;
  }

  // The pixel-centre rectangle of this subgroup's invocations, its size, and this
  // invocation's rank in it (ranks follow invocation ids, as ballot bits do).
  const vec2 corner = vec2(tile * SPLAT_TILE) + 0.5;
  const float x0 = corner.x + float(subgroupMin(column)), x1 = corner.x + float(subgroupMax(column));
  const float y0 = corner.y + float(subgroupMin(row0)), y1 = corner.y + float(subgroupMax(row0) + ROWS - 1u);
  const uint lanes = subgroupAdd(1u);
  const uint rank = subgroupExclusiveAdd(1u);

  for (uint base = range.x; base < range.y; base += lanes) {
    bool all_done = true;
    [[unroll]] for (uint k = 0u; k < ROWS; ++k) all_done = all_done && done[k];
    if (subgroupAll(all_done)) break;  // uniform within the subgroup
    const uint idx = base + rank;
    vec4 cdo_mine = vec4(0.0), conic_mine = vec4(0.0), colour_mine = vec4(0.0);
    bool reach = false;
    const uint slot = idx < range.y ? vals[idx] : SPLAT_SENTINEL_SLOT;
    if (slot != SPLAT_SENTINEL_SLOT) {
      const GpuProjected pr = load_projected(slot);
      cdo_mine = pr.centre_depth_opacity;
      conic_mine = pr.conic;
      colour_mine = pr.colour;
      reach = rect_reachable(pr.conic.xyz, pr.centre_depth_opacity.xy, exact_cull_qmax(pr.centre_depth_opacity.w), x0,
                             x1, y0, y1);
    }
    const uvec4 ballot = subgroupBallot(reach);
    [[unroll]] for (uint word = 0u; word < BALLOT_WORDS; ++word) {
     uint bits = ballot[word];
     while (bits != 0u) {
      const uint src = 32u * word + findLSB(bits);
      bits &= bits - 1u;
      const vec4 cdo = subgroupBroadcast(cdo_mine, src);
      const vec3 conic = subgroupBroadcast(conic_mine.xyz, src);
      const vec3 colour = subgroupBroadcast(colour_mine.rgb, src);
      const float dx = cdo.x - px;
      [[unroll]] for (uint k = 0u; k < ROWS; ++k) {
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
  }
  [[unroll]] for (uint k = 0u; k < ROWS; ++k) {
    const uint y = tile.y * SPLAT_TILE + row0 + k;
    if (x < view.size.x && y < view.size.y) {
      const vec3 final_colour = C[k] + T[k] * background[k];
      out_pixels[y * view.size.x + x] = to_unorm8(final_colour.r) | (to_unorm8(final_colour.g) << 8u) |
                                        (to_unorm8(final_colour.b) << 16u) | (255u << 24u);
    }
  }
}
