#pragma once
// Private to the engine's selection: the view utility of bounding spheres for one pose, over
// structure-of-arrays terms. The Selector scores every Gaussian with it, and the LoD cutter
// every hierarchy node (lod_cut.cpp), so the two rank by the same view terms: angular radius
// times a facing factor that is 1 in the frustum and ramps down to out_of_view_weight over
// margin_deg outside it (selector.h). The ramp, instead of a hard edge, keeps a small head
// turn from changing any utility by more than a few percent, which the retention bonus
// absorbs.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <numbers>

#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "gauss/engine/selector.h"

namespace gauss::select_detail {

struct ViewParams {
  float row[3][3];
  float cx, cy, cz;
  float ftx, fty, inv_kx, inv_ky, inv_ramp, near, out_w, bonus;
};

inline ViewParams make_view_params(const ClientPose& pose, const SelectorConfig& cfg) {
  const glm::dmat3 r_wh = glm::mat3_cast(glm::normalize(pose.orientation));
  const glm::dmat3 r_hw = glm::transpose(r_wh);
  ViewParams vp;
  // Row i of r_hw maps world offsets to head axis i (GLM is column-major: m[col][row]).
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) vp.row[i][j] = static_cast<float>(r_hw[j][i]);
  vp.cx = static_cast<float>(pose.position.x);
  vp.cy = static_cast<float>(pose.position.y);
  vp.cz = static_cast<float>(pose.position.z);
  vp.ftx = static_cast<float>(pose.tan_half_fov_x);
  vp.fty = static_cast<float>(pose.tan_half_fov_y);
  vp.inv_kx = static_cast<float>(1.0 / std::sqrt(1.0 + pose.tan_half_fov_x * pose.tan_half_fov_x));
  vp.inv_ky = static_cast<float>(1.0 / std::sqrt(1.0 + pose.tan_half_fov_y * pose.tan_half_fov_y));
  // Outside-ness e = (distance of the sphere beyond a side plane) / distance ~ sine of the
  // angle outside; the ramp spans e in [0, sin(margin)].
  vp.inv_ramp = 1.0f / static_cast<float>(std::sin(std::clamp(cfg.margin_deg, 0.1, 90.0) * std::numbers::pi / 180.0));
  vp.near = static_cast<float>(cfg.near_distance);
  vp.out_w = static_cast<float>(cfg.out_of_view_weight);
  // Rounded through 1 + bonus in float, as the keys (and the selector's walk digest) always were.
  vp.bonus = static_cast<float>(1.0 + cfg.retention_bonus) - 1.0f;
  return vp;
}

// View utility keys (the float's bits: keys order as the utilities do) for n spheres:
// weight x radius / distance x facing x (1 + bonus if resident), 0 where part is 0. `weight`
// null: 1; `part` null: every sphere counts. This loop is most of a pose update's cost, so it
// reads only the structure-of-arrays terms and has no data-dependent branches.
#if defined(__x86_64__)
// The same loop eight at a time with AVX2 (view_score_avx2.cpp), for CPUs that have it: the
// same operations in the same order again (no FMA), so the same keys. Returns how many
// spheres it scored (a multiple of 8); the caller scores the rest.
template <bool kWeighted, bool kPartitioned>
std::size_t score_view_avx2(std::size_t n, const float* px, const float* py, const float* pz, const float* radius,
                            const float* weight, const std::uint8_t* part, const std::uint8_t* resident,
                            const ViewParams& v, std::uint32_t* out);
// Whether score_view uses it: the CPU has AVX2 and GAUSS_SIMD is not "sse2" (read each call,
// so a test can compare both paths in one process).
bool use_avx2();
#endif

template <bool kWeighted, bool kPartitioned>
void score_view_impl(std::size_t n, const float* __restrict px, const float* __restrict py,
                     const float* __restrict pz, const float* __restrict radius, const float* __restrict weight,
                     const std::uint8_t* __restrict part, const std::uint8_t* __restrict resident,
                     const ViewParams& v, std::uint32_t* __restrict out) {
  const ViewParams p = v;
  std::size_t i = 0;
#if defined(__x86_64__)
  if (n >= 8 && use_avx2())
    i = score_view_avx2<kWeighted, kPartitioned>(n, px, py, pz, radius, weight, part, resident, p, out);
#endif
#if defined(__SSE2__)
  // Four at a time with SSE2: the same operations in the same order as the scalar loop
  // below (IEEE add/mul/div/sqrt are exactly rounded), so the keys are bit-identical.
  {
    auto set = [](float x) { return _mm_set1_ps(x); };
    const __m128 cx = set(p.cx), cy = set(p.cy), cz = set(p.cz);
    const __m128 r00 = set(p.row[0][0]), r01 = set(p.row[0][1]), r02 = set(p.row[0][2]);
    const __m128 r10 = set(p.row[1][0]), r11 = set(p.row[1][1]), r12 = set(p.row[1][2]);
    const __m128 r20 = set(p.row[2][0]), r21 = set(p.row[2][1]), r22 = set(p.row[2][2]);
    const __m128 ftx = set(p.ftx), fty = set(p.fty), inv_kx = set(p.inv_kx), inv_ky = set(p.inv_ky);
    const __m128 near = set(p.near), one = set(1.0f), out_w = set(p.out_w), slope = set(1.0f - p.out_w);
    const __m128 inv_ramp = set(p.inv_ramp), bonus = set(p.bonus);
    const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7FFFFFFF));
    const __m128i zero = _mm_setzero_si128();
    auto widen = [&](const std::uint8_t* b) {  // 4 bytes -> 4 x int32
      std::int32_t w;
      std::memcpy(&w, b, 4);
      return _mm_unpacklo_epi16(_mm_unpacklo_epi8(_mm_cvtsi32_si128(w), zero), zero);
    };
    for (; i + 4 <= n; i += 4) {
      const __m128 dx = _mm_sub_ps(_mm_loadu_ps(px + i), cx);
      const __m128 dy = _mm_sub_ps(_mm_loadu_ps(py + i), cy);
      const __m128 dz = _mm_sub_ps(_mm_loadu_ps(pz + i), cz);
      const __m128 hx = _mm_add_ps(_mm_add_ps(_mm_mul_ps(r00, dx), _mm_mul_ps(r01, dy)), _mm_mul_ps(r02, dz));
      const __m128 hy = _mm_add_ps(_mm_add_ps(_mm_mul_ps(r10, dx), _mm_mul_ps(r11, dy)), _mm_mul_ps(r12, dz));
      const __m128 hz = _mm_add_ps(_mm_add_ps(_mm_mul_ps(r20, dx), _mm_mul_ps(r21, dy)), _mm_mul_ps(r22, dz));
      const __m128 r = _mm_loadu_ps(radius + i);
      const __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
      const __m128 inv_dist = _mm_div_ps(one, _mm_max_ps(_mm_sqrt_ps(d2), near));
      const __m128 ex = _mm_sub_ps(_mm_mul_ps(_mm_sub_ps(_mm_and_ps(hx, abs_mask), _mm_mul_ps(ftx, hz)), inv_kx), r);
      const __m128 ey = _mm_sub_ps(_mm_mul_ps(_mm_sub_ps(_mm_and_ps(hy, abs_mask), _mm_mul_ps(fty, hz)), inv_ky), r);
      const __m128 outside = _mm_mul_ps(_mm_max_ps(ex, ey), inv_dist);
      const __m128 ramp = _mm_sub_ps(one, _mm_mul_ps(_mm_mul_ps(slope, outside), inv_ramp));
      const __m128 facing = _mm_min_ps(_mm_max_ps(ramp, out_w), one);
      const __m128 keep = _mm_add_ps(one, _mm_mul_ps(bonus, _mm_cvtepi32_ps(widen(resident + i))));
      const __m128 wr = kWeighted ? _mm_mul_ps(_mm_loadu_ps(weight + i), r) : r;
      const __m128 view = _mm_mul_ps(_mm_mul_ps(_mm_mul_ps(wr, inv_dist), facing), keep);
      __m128i key = _mm_castps_si128(view);
      if constexpr (kPartitioned) key = _mm_andnot_si128(_mm_cmpeq_epi32(widen(part + i), zero), key);
      _mm_storeu_si128(reinterpret_cast<__m128i*>(out + i), key);
    }
  }
#endif
  for (; i < n; ++i) {
    const float dx = px[i] - p.cx;
    const float dy = py[i] - p.cy;
    const float dz = pz[i] - p.cz;
    const float hx = p.row[0][0] * dx + p.row[0][1] * dy + p.row[0][2] * dz;
    const float hy = p.row[1][0] * dx + p.row[1][1] * dy + p.row[1][2] * dz;
    const float hz = p.row[2][0] * dx + p.row[2][1] * dy + p.row[2][2] * dz;
    const float r = radius[i];
    const float inv_dist = 1.0f / std::max(std::sqrt(dx * dx + dy * dy + dz * dz), p.near);
    // Signed distances beyond the side planes (normalised by the plane normals' length).
    const float ex = (std::fabs(hx) - p.ftx * hz) * p.inv_kx - r;
    const float ey = (std::fabs(hy) - p.fty * hz) * p.inv_ky - r;
    const float outside = std::max(ex, ey) * inv_dist;
    const float facing = std::min(std::max(1.0f - (1.0f - p.out_w) * outside * p.inv_ramp, p.out_w), 1.0f);
    const float keep = 1.0f + p.bonus * static_cast<float>(resident[i]);
    const float wr = kWeighted ? weight[i] * r : r;
    const float view = wr * inv_dist * facing * keep;  // finite and >= 0 for finite spheres
    const std::uint32_t key = std::bit_cast<std::uint32_t>(view);
    out[i] = !kPartitioned || part[i] != 0 ? key : 0u;
  }
}

// The selector's form: weighted, 0 where part is 0.
inline void score_view(std::size_t n, const float* px, const float* py, const float* pz, const float* radius,
                       const float* weight, const std::uint8_t* part, const std::uint8_t* resident,
                       const ViewParams& v, std::uint32_t* out) {
  score_view_impl<true, true>(n, px, py, pz, radius, weight, part, resident, v, out);
}

// The LoD cutter's form: every sphere counts, weight 1.
inline void score_view_spheres(std::size_t n, const float* px, const float* py, const float* pz,
                               const float* radius, const std::uint8_t* resident, const ViewParams& v,
                               std::uint32_t* out) {
  score_view_impl<false, false>(n, px, py, pz, radius, nullptr, nullptr, resident, v, out);
}

}  // namespace gauss::select_detail
