// Per-Gaussian quantisation: the 15-byte record (+ SH rest bytes), its inverse, the
// record hash the differ compares, and fitting quantiser ranges to a scene.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <glm/common.hpp>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "codec/record_bits.h"
#include "gauss/engine/codec.h"

namespace gauss {
namespace {

constexpr double kInvSqrt2 = 0.70710678118654752440;

// Largest code of a `bits`-bit field. Symmetric ranges ([-a, a]: rotation, SH rest) use
// one code fewer so the odd code count puts a code exactly on 0: identity rotations and
// zero SH coefficients are common and must survive exactly.
constexpr std::uint32_t max_code_of(int bits, bool symmetric) {
  return (1u << bits) - (symmetric ? 2u : 1u);
}

// std::nearbyint of 0 <= v < 2^52, inline: after adding 2^52 no fraction bits are left, so
// the sum is rounded by the default mode (to nearest, ties to even) exactly as nearbyint
// rounds, and the subtraction is exact. On baseline x86-64 nearbyint is a library call per
// field, a third of hashing a record (Differ) and encoding one.
double round_non_negative(double v) { return (v + 0x1p52) - 0x1p52; }

// Uniform quantiser of x in [lo, hi] to a code in [0, max_code]: out-of-range input
// clamps to the end codes (counted), never wraps; NaN maps to the middle code (counted).
// Inlined into write_record, whose twenty-odd fields then overlap their divisions instead
// of waiting out a call each (the Differ hashes every record that enters a client's set).
[[gnu::always_inline]] inline std::uint32_t quantize_uniform(double x, double lo, double hi, std::uint32_t max_code, std::uint64_t* clamped,
                               std::uint64_t* non_finite) {
  if (!std::isfinite(x)) {
    if (std::isnan(x)) {
      if (non_finite) ++*non_finite;
      return max_code / 2u;
    }
    if (clamped) ++*clamped;
    return x > 0 ? max_code : 0u;
  }
  if (x < lo || x > hi) {
    if (clamped) ++*clamped;
    return x < lo ? 0u : max_code;
  }
  const double t = (hi > lo) ? (x - lo) / (hi - lo) : 0.0;
  const double code = round_non_negative(t * max_code);  // t in [0, 1]
  return static_cast<std::uint32_t>(std::clamp(code, 0.0, static_cast<double>(max_code)));
}

double dequantize_uniform(std::uint32_t code, double lo, double hi, std::uint32_t max_code) {
  // A hostile record may hold the one unused code of a symmetric field: clamp it.
  code = std::min(code, max_code);
  return lo + (hi - lo) * static_cast<double>(code) / static_cast<double>(max_code);
}

// quantize_uniform of n values at once, for the common case where every one is finite and
// inside its range with lo < hi: then neither the clamps nor the NaN rule apply, and the
// codes are the scalar quantiser's own operations in the same order, two lanes at a time
// (IEEE subtraction, division, multiplication and addition are exactly rounded per lane,
// so each code is bit for bit the scalar one). Returns false when any value is not; the
// caller then quantises them one by one, counting clamps and NaNs. A record hash (Differ)
// and an encode quantise twenty to sixty fields each; one call per field, with its range
// checks, was most of that.
// `Range` gives (lo, hi, top) of value i; the two forms below: per value, and one range.
template <class Range>
bool quantize_in_range(std::size_t n, const double* x, Range range, std::uint32_t* out) {
  std::size_t i = 0;
#if defined(__SSE2__)
  // Adding 2^52 rounds as round_non_negative does; the code is then the low word of the
  // sum's bits (codes are exact integers below 2^32).
  const __m128d shift = _mm_set1_pd(0x1p52);
  __m128d inside = _mm_castsi128_pd(_mm_set1_epi32(-1));
  for (; i + 2 <= n; i += 2) {
    const auto [l0, h0, t0] = range(i);
    const auto [l1, h1, t1] = range(i + 1);
    const __m128d xv = _mm_loadu_pd(x + i), lv = _mm_set_pd(l1, l0), hv = _mm_set_pd(h1, h0);
    inside = _mm_and_pd(inside, _mm_and_pd(_mm_and_pd(_mm_cmpge_pd(xv, lv), _mm_cmple_pd(xv, hv)), _mm_cmplt_pd(lv, hv)));
    const __m128d t = _mm_div_pd(_mm_sub_pd(xv, lv), _mm_sub_pd(hv, lv));
    alignas(16) double c[2];
    _mm_store_pd(c, _mm_add_pd(_mm_mul_pd(t, _mm_set_pd(t1, t0)), shift));
    out[i] = static_cast<std::uint32_t>(std::bit_cast<std::uint64_t>(c[0]));
    out[i + 1] = static_cast<std::uint32_t>(std::bit_cast<std::uint64_t>(c[1]));
  }
  if (_mm_movemask_pd(inside) != 3) return false;
#endif
  for (; i < n; ++i) {
    const auto [lo, hi, top] = range(i);
    if (!(x[i] >= lo && x[i] <= hi && lo < hi)) return false;
    out[i] = static_cast<std::uint32_t>(round_non_negative((x[i] - lo) / (hi - lo) * top));
  }
  return true;
}

struct FieldRange {
  double lo, hi, top;
};

// Smallest-three: the largest-magnitude component is dropped (its index kept) and
// made non-negative (q and -q are the same rotation), so the other three lie in
// [-1/sqrt2, 1/sqrt2].
void quantize_rotation(const glm::vec4& q_in, std::uint32_t& index, std::uint32_t codes[3], CodecStats* stats) {
  double q[4] = {q_in[0], q_in[1], q_in[2], q_in[3]};
  bool finite = true;
  for (double c : q) finite = finite && std::isfinite(c);
  double len2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
  if (!finite || !(len2 > 0.0) || !std::isfinite(len2)) {
    if (!finite && stats) ++stats->non_finite;
    q[0] = 1.0;  // identity: the documented choice for an undefined rotation
    q[1] = q[2] = q[3] = 0.0;
    len2 = 1.0;
  }
  const double inv = 1.0 / std::sqrt(len2);
  for (double& c : q) c *= inv;
  index = 0;
  for (std::uint32_t i = 1; i < 4; ++i) {
    if (std::fabs(q[i]) > std::fabs(q[index])) index = i;
  }
  const double sign = q[index] < 0.0 ? -1.0 : 1.0;
  int k = 0;
  for (std::uint32_t i = 0; i < 4; ++i) {
    if (i == index) continue;
    // |component| <= 1/sqrt2 by construction; rounding cannot leave the range.
    codes[k++] = quantize_uniform(sign * q[i], -kInvSqrt2, kInvSqrt2, max_code_of(kRotationBits, true), nullptr, nullptr);
  }
}

glm::vec4 dequantize_rotation(std::uint32_t index, const std::uint32_t codes[3]) {
  double q[4];
  double sum = 0.0;
  int k = 0;
  for (std::uint32_t i = 0; i < 4; ++i) {
    if (i == index) continue;
    q[i] = dequantize_uniform(codes[k++], -kInvSqrt2, kInvSqrt2, max_code_of(kRotationBits, true));
    sum += q[i] * q[i];
  }
  q[index] = std::sqrt(std::max(0.0, 1.0 - sum));
  const double len = std::sqrt(sum + q[index] * q[index]);
  glm::vec4 out;
  for (int i = 0; i < 4; ++i) out[i] = static_cast<float>(q[i] / len);
  return out;
}

double sigmoid(double x) { return 1.0 / (1.0 + std::exp(-x)); }

std::uint32_t quantize_support(std::uint32_t s, CodecStats* stats) {
  const double code = std::nearbyint(kSupportCodeSteps * std::log2(1.0 + static_cast<double>(s)));
  if (code > static_cast<double>(kMaxSupportCode)) {
    if (stats) ++stats->support_clamped;
    return kMaxSupportCode;
  }
  return static_cast<std::uint32_t>(code);
}

}  // namespace

namespace codec_detail {

std::uint32_t dequantize_support(std::uint8_t code) {
  // A hostile payload cannot pass a larger code (the column reader checks), but clamp
  // anyway so this stays total.
  const unsigned c = std::min<unsigned>(code, kMaxSupportCode);
  return static_cast<std::uint32_t>(std::nearbyint(std::exp2(c / static_cast<double>(kSupportCodeSteps)) - 1.0));
}

std::uint8_t support_code(std::uint32_t support, CodecStats* stats) {
  return static_cast<std::uint8_t>(quantize_support(support, stats));
}

void write_record(const Gaussian& g, const CodecParams& p, std::uint8_t* out, CodecStats* stats) {
  std::uint64_t* pos_clamp = stats ? &stats->position_clamped : nullptr;
  std::uint64_t* nf = stats ? &stats->non_finite : nullptr;
  // The uniform fields of the 15-byte head: position, log-scale, DC colour (codes in that
  // order), in one go where all lie inside their ranges, else one by one (counting).
  std::uint32_t head[9];
  {
    double x[9], lo[9], hi[9], top[9];
    auto per_value = [&](std::size_t i) { return FieldRange{lo[i], hi[i], top[i]}; };
    for (int a = 0; a < 3; ++a) {
      x[a] = g.position[a];
      lo[a] = p.box.min[a];
      hi[a] = p.box.max[a];
      top[a] = max_code_of(kPositionBits, false);
      x[3 + a] = g.log_scale[a];
      lo[3 + a] = p.log_scale_min;
      hi[3 + a] = p.log_scale_max;
      top[3 + a] = max_code_of(kLogScaleBits, false);
      x[6 + a] = g.sh_dc[a];
      lo[6 + a] = p.dc_min;
      hi[6 + a] = p.dc_max;
      top[6 + a] = max_code_of(kDcBits, false);
    }
    if (!quantize_in_range(9, x, per_value, head)) {
      for (int a = 0; a < 3; ++a) {
        double xa = x[a];
        if (std::isnan(xa)) {  // NaN position: the box centre, counted
          if (nf) ++*nf;
          xa = 0.5 * (lo[a] + hi[a]);
        }
        head[a] = quantize_uniform(xa, lo[a], hi[a], max_code_of(kPositionBits, false), pos_clamp, nf);
        head[3 + a] = quantize_uniform(x[3 + a], lo[3 + a], hi[3 + a], max_code_of(kLogScaleBits, false),
                                       stats ? &stats->log_scale_clamped : nullptr, nf);
        head[6 + a] = quantize_uniform(x[6 + a], lo[6 + a], hi[6 + a], max_code_of(kDcBits, false),
                                       stats ? &stats->dc_clamped : nullptr, nf);
      }
    }
  }
  BitWriter128 w;
  for (int a = 0; a < 3; ++a) w.put(head[a], kPositionBits);
  std::uint32_t rot_index = 0;
  std::uint32_t rot_codes[3];
  quantize_rotation(g.rotation, rot_index, rot_codes, stats);
  w.put(rot_index, 2);
  for (std::uint32_t c : rot_codes) w.put(c, kRotationBits);
  for (int a = 0; a < 3; ++a) w.put(head[3 + a], kLogScaleBits);
  // Opacity in sigmoid space: +-Inf logits are legitimate limits (0 and 1), NaN is not.
  double logit = g.opacity_logit;
  if (std::isnan(logit)) {
    if (nf) ++*nf;
    logit = 0.0;
  }
  w.put(quantize_uniform(sigmoid(logit), 0.0, 1.0, max_code_of(kOpacityBits, false), nullptr, nullptr), kOpacityBits);
  for (int a = 0; a < 3; ++a) w.put(head[6 + a], kDcBits);
  w.store(out, static_cast<int>(kRecordBytesSh0));
  // SH rest, one byte each: likewise in one go where all are inside the symmetric range.
  const int rest = 3 * sh_rest_count(std::clamp(p.sh_degree, 0, kMaxShDegree));
  const double bound = p.sh_rest_abs_max;
  constexpr std::uint32_t kRestTop = max_code_of(kShRestBits, true);
  double x[3 * kMaxShRest];
  std::uint32_t codes[3 * kMaxShRest];
  for (int i = 0; i < rest; ++i) x[i] = g.sh_rest[static_cast<std::size_t>(i / 3)][i % 3];
  const FieldRange rest_range{-bound, bound, double(kRestTop)};
  if (!quantize_in_range(static_cast<std::size_t>(rest), x, [&](std::size_t) { return rest_range; }, codes)) {
    for (int i = 0; i < rest; ++i)
      codes[i] = quantize_uniform(x[i], -bound, bound, kRestTop, stats ? &stats->sh_rest_clamped : nullptr, nf);
  }
  std::uint8_t* r = out + kRecordBytesSh0;
  for (int i = 0; i < rest; ++i) r[i] = static_cast<std::uint8_t>(codes[i]);
}

void read_record(const std::uint8_t* in, const CodecParams& p, Gaussian& g) {
  BitReader128 r(in, static_cast<int>(kRecordBytesSh0));
  for (int a = 0; a < 3; ++a) {
    g.position[a] = static_cast<float>(dequantize_uniform(r.get(kPositionBits), p.box.min[a], p.box.max[a],
                                                          max_code_of(kPositionBits, false)));
  }
  const std::uint32_t rot_index = r.get(2);
  std::uint32_t rot_codes[3];
  for (std::uint32_t& c : rot_codes) c = r.get(kRotationBits);
  g.rotation = dequantize_rotation(rot_index, rot_codes);
  for (int a = 0; a < 3; ++a) {
    g.log_scale[a] = static_cast<float>(
        dequantize_uniform(r.get(kLogScaleBits), p.log_scale_min, p.log_scale_max, max_code_of(kLogScaleBits, false)));
  }
  // The end codes would decode to logits of -Inf/+Inf; a quarter step inside keeps the
  // value finite and still within the stated half-step bound.
  const double lim = 0.25 / static_cast<double>(max_code_of(kOpacityBits, false));
  const double opacity =
      std::clamp(dequantize_uniform(r.get(kOpacityBits), 0.0, 1.0, max_code_of(kOpacityBits, false)), lim, 1.0 - lim);
  g.opacity_logit = static_cast<float>(std::log(opacity / (1.0 - opacity)));
  for (int c = 0; c < 3; ++c) {
    g.sh_dc[c] = static_cast<float>(dequantize_uniform(r.get(kDcBits), p.dc_min, p.dc_max, max_code_of(kDcBits, false)));
  }
  g.sh_rest = {};
  const int rest = sh_rest_count(std::clamp(p.sh_degree, 0, kMaxShDegree));
  const std::uint8_t* s = in + kRecordBytesSh0;
  for (int k = 0; k < rest; ++k) {
    for (int c = 0; c < 3; ++c) {
      g.sh_rest[static_cast<std::size_t>(k)][c] = static_cast<float>(
          dequantize_uniform(*s++, -p.sh_rest_abs_max, p.sh_rest_abs_max, max_code_of(kShRestBits, true)));
    }
  }
  g.carrier = false;
}

}  // namespace codec_detail

void quantize_record(const Gaussian& g, const CodecParams& params, std::uint8_t* out, CodecStats* stats) {
  codec_detail::write_record(g, params, out, stats);
}

void write_sent_record(const Gaussian& g, const CodecParams& params, std::uint8_t* out) {
  codec_detail::write_record(g, params, out, nullptr);
  const std::size_t n = record_bytes(std::clamp(params.sh_degree, 0, kMaxShDegree));
  const auto obj = static_cast<std::uint32_t>(to_underlying(g.object));
  std::memcpy(out + n, &obj, 4);
  out[n + 4] = codec_detail::support_code(g.support, nullptr);
}

Gaussian read_sent_record(const std::uint8_t* in, GaussianId id, const CodecParams& params) {
  const std::size_t n = record_bytes(std::clamp(params.sh_degree, 0, kMaxShDegree));
  Gaussian out;
  codec_detail::read_record(in, params, out);
  std::uint32_t obj;
  std::memcpy(&obj, in + n, 4);
  out.id = id;
  out.object = ObjectId{static_cast<std::int32_t>(obj)};
  out.support = codec_detail::dequantize_support(in[n + 4]);
  return out;
}

Gaussian quantize_roundtrip(const Gaussian& g, const CodecParams& params) {
  std::uint8_t buf[record_bytes(kMaxShDegree)];
  codec_detail::write_record(g, params, buf, nullptr);
  Gaussian out;
  codec_detail::read_record(buf, params, out);
  out.id = g.id;
  out.object = g.object;
  out.support = codec_detail::dequantize_support(codec_detail::support_code(g.support, nullptr));
  return out;
}

Status validate_codec_params(const CodecParams& p) {
  auto bad = [](const std::string& what) { return Status(Error{"codec params: " + what}); };
  if (p.sh_degree < 0 || p.sh_degree > kMaxShDegree) {
    return bad("sh_degree " + std::to_string(p.sh_degree) + " outside 0..3");
  }
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(p.box.min[a]) || !std::isfinite(p.box.max[a]) || !(p.box.min[a] < p.box.max[a])) {
      return bad("box axis " + std::to_string(a) + " is empty or not finite");
    }
  }
  auto range_ok = [](float lo, float hi) { return std::isfinite(lo) && std::isfinite(hi) && lo < hi; };
  if (!range_ok(p.log_scale_min, p.log_scale_max)) return bad("log-scale range empty or not finite");
  if (!range_ok(p.dc_min, p.dc_max)) return bad("SH0 range empty or not finite");
  if (!std::isfinite(p.sh_rest_abs_max) || !(p.sh_rest_abs_max > 0.0f)) {
    return bad("sh_rest_abs_max must be finite and > 0");
  }
  return Ok{};
}

namespace {

// Value at quantile q of the finite values (nth_element: O(n)); fallback when none.
float quantile(std::vector<float>& v, double q, float fallback) {
  if (v.empty()) return fallback;
  const auto k = static_cast<std::size_t>(std::clamp(q, 0.0, 1.0) * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// The value at quantile q of the |x| of the finite SH rest coefficients: exactly what
// quantile() over them gives, without holding them. At SH 3 a scene has 45 per Gaussian (45M
// floats, 180 MB, at 1M Gaussians), and collecting them and selecting took most of a 1M
// scene's fit. The bits of a non-negative float order as its value does, and equal values
// have equal bits (fabs makes -0 +0), so the k-th smallest is found by counting: its high
// 16 bits from a histogram of all values, then its low 16 bits from one of the values with
// those high bits. Two passes over the scene, 512 KiB of counts.
float sh_rest_abs_quantile(std::span<const Gaussian> gaussians, int rest, double q, float fallback) {
  auto for_each_abs = [&](auto&& visit) {
    for (const Gaussian& g : gaussians)
      for (int k = 0; k < rest; ++k)
        for (int c = 0; c < 3; ++c) {
          const float x = g.sh_rest[static_cast<std::size_t>(k)][c];
          if (std::isfinite(x)) visit(std::bit_cast<std::uint32_t>(std::fabs(x)));
        }
  };
  std::vector<std::uint64_t> count(std::size_t{1} << 16, 0);
  std::uint64_t n = 0;
  for_each_abs([&](std::uint32_t b) {
    ++count[b >> 16];
    ++n;
  });
  if (n == 0) return fallback;
  auto k = static_cast<std::uint64_t>(std::clamp(q, 0.0, 1.0) * static_cast<double>(n - 1));
  std::uint32_t high = 0;
  while (k >= count[high]) k -= count[high++];
  std::fill(count.begin(), count.end(), 0);
  for_each_abs([&](std::uint32_t b) {
    if ((b >> 16) == high) ++count[b & 0xFFFFu];
  });
  std::uint32_t low = 0;
  while (k >= count[low]) k -= count[low++];
  return std::bit_cast<float>((high << 16) | low);
}

}  // namespace

CodecParams fit_codec_params(std::span<const Gaussian> gaussians, int sh_degree) {
  CodecParams p;
  p.sh_degree = std::clamp(sh_degree, 0, kMaxShDegree);
  constexpr double kLo = 0.0005;
  constexpr double kHi = 0.9995;
  std::vector<float> v;
  v.reserve(gaussians.size() * 3);
  // Log-scales use their exact range: clamping the few largest Gaussians shrinks what
  // covers the most pixels (on a real trained scene, 0.05 % clipped cost 30 dB of PSNR),
  // and the log range is compact anyway. SH0 and SH rest use quantiles: a clipped outlier
  // colour coefficient changes one splat's tint, while a wide range coarsens every step.
  // Box: exact bounds of the finite positions (a position outside the box costs its
  // Gaussian a clamp; a wide box costs every Gaussian precision, but the box is the
  // scene's, so no Gaussian should be clamped).
  glm::vec3 lo(std::numeric_limits<float>::max());
  glm::vec3 hi(std::numeric_limits<float>::lowest());
  bool any = false;
  for (const Gaussian& g : gaussians) {
    if (!std::isfinite(g.position.x) || !std::isfinite(g.position.y) || !std::isfinite(g.position.z)) continue;
    lo = glm::min(lo, g.position);
    hi = glm::max(hi, g.position);
    any = true;
  }
  if (any) {
    const glm::vec3 pad = glm::max((hi - lo) * 0.01f, glm::vec3(1e-3f));
    p.box.min = lo - pad;
    p.box.max = hi + pad;
  }
  // [a, b] widened about its middle to at least min_span.
  auto set_range = [](float a, float b, float min_span, float& out_lo, float& out_hi) {
    if (!(b - a >= min_span)) {
      const float mid = 0.5f * (a + b);
      a = mid - 0.5f * min_span;
      b = mid + 0.5f * min_span;
    }
    out_lo = a;
    out_hi = b;
  };
  {
    // The exact range (quantiles 0 and 1): a min/max scan.
    float a = std::numeric_limits<float>::max(), b = std::numeric_limits<float>::lowest();
    for (const Gaussian& g : gaussians)
      for (int i = 0; i < 3; ++i)
        if (std::isfinite(g.log_scale[i])) {
          a = std::min(a, g.log_scale[i]);
          b = std::max(b, g.log_scale[i]);
        }
    if (a <= b) set_range(a, b, 1.0f, p.log_scale_min, p.log_scale_max);
  }
  for (const Gaussian& g : gaussians)
    for (int c = 0; c < 3; ++c)
      if (std::isfinite(g.sh_dc[c])) v.push_back(g.sh_dc[c]);
  if (!v.empty()) set_range(quantile(v, kLo, p.dc_min), quantile(v, kHi, p.dc_max), 0.5f, p.dc_min, p.dc_max);
  if (p.sh_degree > 0)
    p.sh_rest_abs_max =
        std::max(sh_rest_abs_quantile(gaussians, sh_rest_count(p.sh_degree), kHi, p.sh_rest_abs_max), 1e-3f);
  return p;
}

CodecParams fit_live_codec_params(std::span<const Gaussian> first_epoch, int sh_degree) {
  CodecParams p = fit_codec_params(first_epoch, sh_degree);
  const glm::vec3 extent = p.box.max - p.box.min;
  p.box.min -= kLiveBoxMargin * extent;
  p.box.max += kLiveBoxMargin * extent;
  return p;
}

}  // namespace gauss
