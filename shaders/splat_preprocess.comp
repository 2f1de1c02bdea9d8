#version 460
// Preprocess, one thread per slot below the high-water mark (splat_math.h steps 0-11):
// projects the slot, computes conic, radius, tile rectangle, colour and opacity, and the
// number of tiles it will be binned into (0 = not drawn). Writes tile_count for every
// slot it covers (0 for empty / culled ones) so the following scan needs no clearing.
// One dispatch per slot chunk (splat_layout.h "Slot chunks"): the core, SH and projected
// bindings hold that chunk only, indexed from pc.first_slot; tile_count and the edit
// words cover every slot.
#extension GL_GOOGLE_include_directive : require

#define SPLAT_USE_VIEW
#include "splat_common.glsl"

layout(local_size_x = SPLAT_WORKGROUP) in;

layout(constant_id = SPLAT_SPEC_SH_DEGREE) const uint SH_DEGREE = 0u;
layout(constant_id = SPLAT_SPEC_TINT) const bool TINT = false;
layout(constant_id = SPLAT_SPEC_MESH) const bool MESH = false;
layout(constant_id = SPLAT_SPEC_SH_STRIDE) const uint SH_STRIDE = 0u;
layout(constant_id = SPLAT_SPEC_EXACT_CULL) const bool EXACT_CULL = true;

layout(std430, binding = SPLAT_BINDING_CORE) readonly buffer CoreBuf { GpuSplatCore cores[]; };
layout(std430, binding = SPLAT_BINDING_SH) readonly buffer ShBuf { float sh_rest[]; };
layout(std430, binding = SPLAT_BINDING_SH_HIGH) readonly buffer ShHighBuf { float sh_rest_high[]; };
layout(std430, binding = SPLAT_BINDING_EDIT) readonly buffer EditBuf { uint edit_words[]; };
layout(std430, binding = SPLAT_BINDING_HIGHLIGHT) readonly buffer HighlightBuf { int highlight_ids[]; };
layout(std430, binding = SPLAT_BINDING_PROJECTED) writeonly buffer ProjBuf { GpuProjected projected[]; };
layout(std430, binding = SPLAT_BINDING_TILE_COUNT) writeonly buffer TileCountBuf { uint tile_count[]; };
layout(std430, binding = SPLAT_BINDING_TILE_DEPTH) readonly buffer TileDepthBuf { float tile_max_depth[]; };
layout(push_constant) uniform Push { GpuSplatPush pc; };

const float SH_C0 = 0.28209479177387814;
const float SH_C1 = 0.4886025119029199;
const float SH_C2[5] = float[5](1.0925484305920792, -1.0925484305920792, 0.31539156525252005,
                                -1.0925484305920792, 0.5462742152960396);
const float SH_C3[7] = float[7](-0.5900435899266435, 2.890611442640554, -0.4570457994644658,
                                0.3731763325901154, -0.4570457994644658, 1.445305721320277,
                                -0.5900435899266435);

// k = 1..15; k is a constant at every call, so each call reads one buffer only.
// `at`: the slot's index in the bound chunk.
vec3 sh_coeff(uint at, uint k) {
  if (k <= SPLAT_SH_LOW_COEFFS) {
    const uint base = at * SH_STRIDE + (k - 1u) * 3u;
    return vec3(sh_rest[base], sh_rest[base + 1u], sh_rest[base + 2u]);
  }
  const uint base = at * SPLAT_SH_HIGH_STRIDE + (k - 1u - SPLAT_SH_LOW_COEFFS) * 3u;
  return vec3(sh_rest_high[base], sh_rest_high[base + 1u], sh_rest_high[base + 2u]);
}

// computeColorFromSH of the reference, before +0.5 and the clamp.
vec3 eval_sh(uint at, vec3 dc, vec3 dir) {
  vec3 result = SH_C0 * dc;
  if (SH_DEGREE > 0u) {
    const float x = dir.x, y = dir.y, z = dir.z;
    result = result - SH_C1 * y * sh_coeff(at, 1u) + SH_C1 * z * sh_coeff(at, 2u) -
             SH_C1 * x * sh_coeff(at, 3u);
    if (SH_DEGREE > 1u) {
      const float xx = x * x, yy = y * y, zz = z * z;
      const float xy = x * y, yz = y * z, xz = x * z;
      result = result + SH_C2[0] * xy * sh_coeff(at, 4u) + SH_C2[1] * yz * sh_coeff(at, 5u) +
               SH_C2[2] * (2.0 * zz - xx - yy) * sh_coeff(at, 6u) + SH_C2[3] * xz * sh_coeff(at, 7u) +
               SH_C2[4] * (xx - yy) * sh_coeff(at, 8u);
      if (SH_DEGREE > 2u) {
        result = result + SH_C3[0] * y * (3.0 * xx - yy) * sh_coeff(at, 9u) +
                 SH_C3[1] * xy * z * sh_coeff(at, 10u) +
                 SH_C3[2] * y * (4.0 * zz - xx - yy) * sh_coeff(at, 11u) +
                 SH_C3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy) * sh_coeff(at, 12u) +
                 SH_C3[4] * x * (4.0 * zz - xx - yy) * sh_coeff(at, 13u) +
                 SH_C3[5] * z * (xx - yy) * sh_coeff(at, 14u) +
                 SH_C3[6] * x * (xx - 3.0 * yy) * sh_coeff(at, 15u);
      }
    }
  }
  return result;
}

bool highlighted(int object) {
  // highlight_ids is sorted ascending; binary search.
  uint lo = 0u, hi = view.frame.z;
  while (lo < hi) {
    const uint mid = (lo + hi) / 2u;
    const int v = highlight_ids[mid];
    if (v == object) return true;
    if (v < object) lo = mid + 1u; else hi = mid;
  }
  return false;
}

vec3 mix_toward(vec3 c, vec3 target, float s) { return c + s * (target - c); }

void main() {
  const uint at = gl_GlobalInvocationID.x;  // index in this dispatch's slot chunk
  if (at >= pc.item_count) return;
  const uint slot = pc.first_slot + at;
  tile_count[slot] = 0u;

  const GpuSplatCore g = cores[at];
  if ((g.flags & SPLAT_FLAG_OCCUPIED) == 0u) return;

  uint edit_kind = 0u, edit_age = 0u;
  if (TINT) {
    const uint w = edit_words[slot];
    edit_kind = w >> SPLAT_EDIT_KIND_SHIFT;
    edit_age = (view.frame.y - (w & SPLAT_EDIT_FRAME_MASK)) & SPLAT_EDIT_FRAME_MASK;
    if (edit_kind == 3u && edit_age >= SPLAT_REMOVED_FADE_FRAMES) return;  // faded out
  }

  // 1-2. View space and near cull.
  const vec3 p = g.position_opacity.xyz;
  const vec4 ph = vec4(p, 1.0);
  const vec3 t = vec3(dot(view.w2c_row0, ph), dot(view.w2c_row1, ph), dot(view.w2c_row2, ph));
  // float(0.2) rounds UP (0.20000000298), so for a float t.z, t.z >= SPLAT_NEAR_CULL is
  // exactly the reference's t.z > 0.2 (a t.z of float(0.2) itself is kept, as there).
  if (!(t.z >= SPLAT_NEAR_CULL)) return;

  // 3. R from the unit quaternion (w, x, y, z), M = W R S.
  const vec4 q = g.rotation;
  const float qr = q.x, qx = q.y, qy = q.z, qz = q.w;
  const mat3 R = mat3(  // column-major: R[col][row]
      1.0 - 2.0 * (qy * qy + qz * qz), 2.0 * (qx * qy + qr * qz), 2.0 * (qx * qz - qr * qy),
      2.0 * (qx * qy - qr * qz), 1.0 - 2.0 * (qx * qx + qz * qz), 2.0 * (qy * qz + qr * qx),
      2.0 * (qx * qz + qr * qy), 2.0 * (qy * qz - qr * qx), 1.0 - 2.0 * (qx * qx + qy * qy));
  const vec3 s = exp(g.log_scale_dc_r.xyz);
  const mat3 W = transpose(mat3(view.w2c_row0.xyz, view.w2c_row1.xyz, view.w2c_row2.xyz));
  const mat3 WRS = W * R * mat3(s.x, 0.0, 0.0, 0.0, s.y, 0.0, 0.0, 0.0, s.z);

  // 4. EWA Jacobian with the frustum clamp; rows of J W R S.
  const float fx = view.intrinsics.x, fy = view.intrinsics.y;
  const float tx = min(view.limits.x, max(-view.limits.x, t.x / t.z)) * t.z;
  const float ty = min(view.limits.y, max(-view.limits.y, t.y / t.z)) * t.z;
  const vec3 row_z = vec3(WRS[0].z, WRS[1].z, WRS[2].z);
  const vec3 m0 = (fx / t.z) * vec3(WRS[0].x, WRS[1].x, WRS[2].x) - (fx * tx / (t.z * t.z)) * row_z;
  const vec3 m1 = (fy / t.z) * vec3(WRS[0].y, WRS[1].y, WRS[2].y) - (fy * ty / (t.z * t.z)) * row_z;
  // cov2D = [[a, b], [b, c]] = M M^T, then dilated. det via Lagrange's identity
  // (a0 c0 - b^2 = |m0 x m1|^2) so that it cannot cancel to zero or below in float:
  // mathematically the same value as the reference's a c - b^2.
  const float a0 = dot(m0, m0), c0 = dot(m1, m1);
  const float b = dot(m0, m1);
  const float a = a0 + SPLAT_DILATION, c = c0 + SPLAT_DILATION;
  const vec3 cr = cross(m0, m1);
  const float det = dot(cr, cr) + SPLAT_DILATION * (a0 + c0) + SPLAT_DILATION * SPLAT_DILATION;
  // 5. det == 0 or a non-finite footprint -> skip.
  if (!(det > 0.0) || isinf(det) || isinf(a) || isinf(c) || isnan(b)) return;
  const vec3 conic = vec3(c / det, -b / det, a / det);
  // 6. Eigenvalues: mid^2 - det == ((a - c) / 2)^2 + b^2, evaluated without cancellation.
  const float mid = 0.5 * (a + c);
  const float half_diff = 0.5 * (a - c);
  const float root = sqrt(max(SPLAT_LAMBDA_FLOOR, half_diff * half_diff + b * b));
  const float lambda1 = mid + root;
  const float radius = ceil(SPLAT_SIGMA_EXTENT * sqrt(lambda1));
  // 7. Centre from the unclamped t.
  const vec2 centre = vec2(fx * t.x / t.z + view.intrinsics.z, fy * t.y / t.z + view.intrinsics.w);
  // 8. Tile rectangle, clamped in float before the integer conversion.
  const vec2 grid = vec2(view.size.zw);
  const vec2 rmin = min(grid, max(vec2(0.0), (centre - radius) / float(SPLAT_TILE)));
  const vec2 rmax = min(grid, max(vec2(0.0), (centre + radius + float(SPLAT_TILE - 1u)) / float(SPLAT_TILE)));
  if (!(radius > 0.0) || isnan(rmin.x) || isnan(rmin.y) || isnan(rmax.x) || isnan(rmax.y)) return;
  const uvec4 rect = uvec4(uvec2(rmin), uvec2(rmax));
  if (rect.z <= rect.x || rect.w <= rect.y) return;

  // 9-10. Colour and opacity.
  const vec3 dir = normalize(p - view.camera_centre.xyz);
  const vec3 dc = vec3(g.log_scale_dc_r.w, g.dc_gb);
  vec3 colour = max(eval_sh(at, dc, dir) + 0.5, vec3(0.0));
  float opacity = 1.0 / (1.0 + exp(-g.position_opacity.w));

  // 11. Tints: highlight first, then the edit visualisation.
  if (TINT) {
    // No `view.frame.z > 0u` guard (highlighted() with none returns at once): lavapipe
    // inlines a UBO word that alone decides a branch and then recompiled this shader on
    // every bind (see tests/render/test_splat_steady_memory.cpp).
    if (highlighted(g.object)) {
      colour = mix_toward(colour, vec3(1.0, 0.8, 0.0), SPLAT_HIGHLIGHT_STRENGTH);
    }
    if ((edit_kind == 1u || edit_kind == 2u) && edit_age < SPLAT_EDIT_TINT_FRAMES) {
      const float st = SPLAT_EDIT_STRENGTH * float(SPLAT_EDIT_TINT_FRAMES - edit_age) / float(SPLAT_EDIT_TINT_FRAMES);
      colour = mix_toward(colour, edit_kind == 1u ? vec3(0.0, 1.0, 0.0) : vec3(0.0, 0.0, 1.0), st);
    } else if (edit_kind == 3u) {
      colour = mix_toward(colour, vec3(1.0, 0.0, 0.0), SPLAT_EDIT_STRENGTH);
      opacity *= float(SPLAT_REMOVED_FADE_FRAMES - edit_age) / float(SPLAT_REMOVED_FADE_FRAMES);
    }
  }

  // Tiles this splat is binned into: the rectangle, minus (exact culling) tiles its
  // alpha cannot reach 1/255 in, minus (mesh) tiles lying wholly in front of it by more
  // than the margin. Neither removal changes the image (see splat_common.glsl and
  // splat_math.h "Mesh"); splat_emit.comp repeats the same test per tile.
  // A splat whose opacity is below 1/255 (with the same 1 % slack) can reach no pixel.
  if (EXACT_CULL && opacity * 1.01 < SPLAT_ALPHA_MIN) return;
  const float q_max = exact_cull_qmax(opacity);
  uint n = 0u;
  for (uint ty = rect.y; ty < rect.w; ++ty) {
    for (uint tx = rect.x; tx < rect.z; ++tx) {
      if (MESH && t.z > tile_max_depth[ty * view.size.z + tx] + view.limits.z) continue;
      if (EXACT_CULL && !tile_reachable(conic, centre, q_max, tx, ty, view.size.x, view.size.y)) continue;
      ++n;
    }
  }
  if (n == 0u) return;

  projected[at].centre_depth_opacity = vec4(centre, t.z, opacity);
  projected[at].conic = vec4(conic, 0.0);
  projected[at].colour = vec4(colour, 0.0);
  projected[at].rect = rect;
  tile_count[slot] = n;
}
