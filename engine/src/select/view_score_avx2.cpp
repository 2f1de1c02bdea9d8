// select/view_score.h's loop eight spheres at a time, compiled for AVX2 whatever the build's
// baseline, and used only where the CPU has it (use_avx2). A pose update scores every
// Gaussian (Selector) or every hierarchy node (LoD cutter): this halves that pass.
#include "select/view_score.h"

#if defined(__x86_64__)
#include <immintrin.h>

#include <cstdlib>
#include <cstring>

namespace gauss::select_detail {

bool use_avx2() {
  static const bool cpu = __builtin_cpu_supports("avx2");
  if (!cpu) return false;
  const char* env = std::getenv("GAUSS_SIMD");
  return !(env && std::strcmp(env, "sse2") == 0);
}

// Everything from here to pop_options is compiled for AVX2; nothing here is inline code shared
// with other files (which the linker could then pick for a CPU without it).
#pragma GCC push_options
#pragma GCC target("avx2")

template <bool kWeighted, bool kPartitioned>
std::size_t score_view_avx2(std::size_t n, const float* px, const float* py, const float* pz, const float* radius,
                            const float* weight, const std::uint8_t* part, const std::uint8_t* resident,
                            const ViewParams& p, std::uint32_t* out) {
  // view_score.h's SSE2 block, lane for lane: the same IEEE operations in the same order.
  const __m256 cx = _mm256_set1_ps(p.cx), cy = _mm256_set1_ps(p.cy), cz = _mm256_set1_ps(p.cz);
  const __m256 r00 = _mm256_set1_ps(p.row[0][0]), r01 = _mm256_set1_ps(p.row[0][1]), r02 = _mm256_set1_ps(p.row[0][2]);
  const __m256 r10 = _mm256_set1_ps(p.row[1][0]), r11 = _mm256_set1_ps(p.row[1][1]), r12 = _mm256_set1_ps(p.row[1][2]);
  const __m256 r20 = _mm256_set1_ps(p.row[2][0]), r21 = _mm256_set1_ps(p.row[2][1]), r22 = _mm256_set1_ps(p.row[2][2]);
  const __m256 ftx = _mm256_set1_ps(p.ftx), fty = _mm256_set1_ps(p.fty), inv_kx = _mm256_set1_ps(p.inv_kx), inv_ky = _mm256_set1_ps(p.inv_ky);
  const __m256 near = _mm256_set1_ps(p.near), one = _mm256_set1_ps(1.0f), out_w = _mm256_set1_ps(p.out_w), slope = _mm256_set1_ps(1.0f - p.out_w);
  const __m256 inv_ramp = _mm256_set1_ps(p.inv_ramp), bonus = _mm256_set1_ps(p.bonus);
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7FFFFFFF));
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 dx = _mm256_sub_ps(_mm256_loadu_ps(px + i), cx);
    const __m256 dy = _mm256_sub_ps(_mm256_loadu_ps(py + i), cy);
    const __m256 dz = _mm256_sub_ps(_mm256_loadu_ps(pz + i), cz);
    const __m256 hx = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(r00, dx), _mm256_mul_ps(r01, dy)), _mm256_mul_ps(r02, dz));
    const __m256 hy = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(r10, dx), _mm256_mul_ps(r11, dy)), _mm256_mul_ps(r12, dz));
    const __m256 hz = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(r20, dx), _mm256_mul_ps(r21, dy)), _mm256_mul_ps(r22, dz));
    const __m256 r = _mm256_loadu_ps(radius + i);
    const __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
    const __m256 inv_dist = _mm256_div_ps(one, _mm256_max_ps(_mm256_sqrt_ps(d2), near));
    const __m256 ex =
        _mm256_sub_ps(_mm256_mul_ps(_mm256_sub_ps(_mm256_and_ps(hx, abs_mask), _mm256_mul_ps(ftx, hz)), inv_kx), r);
    const __m256 ey =
        _mm256_sub_ps(_mm256_mul_ps(_mm256_sub_ps(_mm256_and_ps(hy, abs_mask), _mm256_mul_ps(fty, hz)), inv_ky), r);
    const __m256 outside = _mm256_mul_ps(_mm256_max_ps(ex, ey), inv_dist);
    const __m256 ramp = _mm256_sub_ps(one, _mm256_mul_ps(_mm256_mul_ps(slope, outside), inv_ramp));
    const __m256 facing = _mm256_min_ps(_mm256_max_ps(ramp, out_w), one);
    const __m256 keep = _mm256_add_ps(one, _mm256_mul_ps(bonus, _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(resident + i))))));
    const __m256 wr = kWeighted ? _mm256_mul_ps(_mm256_loadu_ps(weight + i), r) : r;
    const __m256 view = _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(wr, inv_dist), facing), keep);
    __m256i key = _mm256_castps_si256(view);
    if constexpr (kPartitioned)
      key = _mm256_andnot_si256(_mm256_cmpeq_epi32(_mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(part + i))), _mm256_setzero_si256()), key);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + i), key);
  }
  return i;
}

template std::size_t score_view_avx2<true, true>(std::size_t, const float*, const float*, const float*, const float*,
                                                 const float*, const std::uint8_t*, const std::uint8_t*,
                                                 const ViewParams&, std::uint32_t*);
template std::size_t score_view_avx2<false, false>(std::size_t, const float*, const float*, const float*, const float*,
                                                   const float*, const std::uint8_t*, const std::uint8_t*,
                                                   const ViewParams&, std::uint32_t*);

#pragma GCC pop_options

}  // namespace gauss::select_detail

#endif
