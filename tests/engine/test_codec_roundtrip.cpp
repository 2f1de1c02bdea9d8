// Edit-batch codec: exact ids/kinds/epoch, the stated decode error bounds, clamping
// (never wrapping) of out-of-range values, and hostile payloads rejected cleanly.
#include <cmath>
#include <algorithm>
#include <cstring>
#include <limits>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <zstd.h>

#include "gauss/engine/codec.h"
#include "opacity.h"

namespace gauss {
namespace {

Gaussian random_gaussian(std::mt19937_64& rng, const CodecParams& p, std::uint64_t id) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> n(0.0f, 1.0f);
  Gaussian g;
  for (int a = 0; a < 3; ++a) {
    g.position[a] = p.box.min[a] + u(rng) * (p.box.max[a] - p.box.min[a]);
    g.log_scale[a] = p.log_scale_min + u(rng) * (p.log_scale_max - p.log_scale_min);
    g.sh_dc[a] = p.dc_min + u(rng) * (p.dc_max - p.dc_min);
  }
  glm::vec4 q{n(rng), n(rng), n(rng), n(rng)};  // braces: drawn in order
  g.rotation = q / std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  g.opacity_logit = n(rng) * 4.0f;
  for (int k = 0; k < sh_rest_count(p.sh_degree); ++k) {
    for (int c = 0; c < 3; ++c) g.sh_rest[static_cast<std::size_t>(k)][c] = (u(rng) * 2.0f - 1.0f) * p.sh_rest_abs_max;
  }
  g.id = GaussianId{id};
  g.object = ObjectId{static_cast<std::int32_t>(rng() % 20) - 1};
  g.support = static_cast<std::uint32_t>(rng() % 5000);
  return g;
}

CodecParams test_params(int degree) {
  CodecParams p;
  p.box = {glm::vec3(-4.0f, -1.0f, -6.0f), glm::vec3(5.0f, 3.0f, 2.0f)};
  p.sh_degree = degree;
  p.log_scale_min = -9.0f;
  p.log_scale_max = 0.5f;
  p.dc_min = -1.7f;
  p.dc_max = 2.1f;
  p.sh_rest_abs_max = 0.6f;
  return p;
}

void expect_within_bounds(const Gaussian& in, const Gaussian& out, const CodecParams& p) {
  const float slack = 1e-6f;  // float rounding of the dequantised value
  for (int a = 0; a < 3; ++a) {
    const double step = (p.box.max[a] - p.box.min[a]) / ((1 << kPositionBits) - 1);
    EXPECT_LE(std::fabs(out.position[a] - in.position[a]), 0.5 * step + slack * 10);
    const double ls = (p.log_scale_max - p.log_scale_min) / 255.0;
    EXPECT_LE(std::fabs(out.log_scale[a] - in.log_scale[a]), 0.5 * ls + slack);
    const double dc = (p.dc_max - p.dc_min) / ((1 << kDcBits) - 1);
    EXPECT_LE(std::fabs(out.sh_dc[a] - in.sh_dc[a]), 0.5 * dc + slack);
  }
  EXPECT_LE(std::fabs(test::sigmoid(out.opacity_logit) - test::sigmoid(in.opacity_logit)), 0.5 / ((1 << kOpacityBits) - 1) + 1e-6);
  double same = 0.0;
  double flip = 0.0;
  for (int i = 0; i < 4; ++i) {
    same = std::max(same, static_cast<double>(std::fabs(out.rotation[i] - in.rotation[i])));
    flip = std::max(flip, static_cast<double>(std::fabs(out.rotation[i] + in.rotation[i])));
  }
  EXPECT_LE(std::min(same, flip), kRotationMaxError);
  for (int k = 0; k < sh_rest_count(p.sh_degree); ++k) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_LE(std::fabs(out.sh_rest[static_cast<std::size_t>(k)][c] - in.sh_rest[static_cast<std::size_t>(k)][c]),
                p.sh_rest_abs_max / 254.0 + slack);
    }
  }
  // Half a code step in log2(1 + s) (1/8), plus the rounding of s' to an integer.
  const double s_in = 1.0 + in.support;
  const double s_out = 1.0 + out.support;
  EXPECT_LE(std::fabs(s_out / s_in - 1.0), std::exp2(0.5 / kSupportCodeSteps) - 1.0 + 0.5 / s_in);
  if (in.support <= 7) {
    EXPECT_EQ(out.support, in.support) << "small counts are exact";
  }
  EXPECT_EQ(out.object, in.object);
  EXPECT_EQ(out.id, in.id);
}

EditBatch random_batch(std::mt19937_64& rng, const CodecParams& p, std::size_t n) {
  EditBatch b;
  b.epoch = Epoch{rng() % 100000};
  std::uint64_t id = rng() % 1000;
  for (std::size_t i = 0; i < n; ++i) {
    id += 1 + rng() % 50;
    Edit e;
    e.kind = static_cast<EditKind>(rng() % 4);
    e.id = GaussianId{id};
    if (e.kind == EditKind::Replace) e.leaving = GaussianId{rng() % 1000000};
    if (e.kind != EditKind::Remove) e.value = random_gaussian(rng, p, id);
    b.edits.push_back(e);
  }
  std::shuffle(b.edits.begin(), b.edits.end(), rng);
  return b;
}

TEST(CodecRoundtrip, BatchIdsKindsEpochExactAndValuesAsQuantizeRoundtrip) {
  std::mt19937_64 rng(7);
  for (int degree = 0; degree <= 3; ++degree) {
    const CodecParams p = test_params(degree);
    const EditBatch in = random_batch(rng, p, 3000);
    CodecStats stats;
    const auto bytes = encode_edit_batch(in, p, &stats);
    EXPECT_EQ(stats.clamped_total(), 0u);
    auto out = decode_edit_batch(bytes, p);
    ASSERT_TRUE(out.ok()) << out.message();
    EXPECT_EQ(out->epoch, in.epoch);
    ASSERT_EQ(out->edits.size(), in.edits.size());
    std::map<std::uint64_t, const Edit*> by_id;
    for (const Edit& e : in.edits) by_id[to_underlying(e.id)] = &e;
    int last_group = -1;
    const int group_of[4] = {3, 0, 2, 1};  // Insert, Remove, Update, Replace -> wire order
    for (const Edit& e : out->edits) {
      const Edit* src = by_id.at(to_underlying(e.id));
      EXPECT_EQ(e.kind, src->kind);
      EXPECT_GE(group_of[static_cast<int>(e.kind)], last_group) << "removes, replaces, updates, inserts";
      last_group = group_of[static_cast<int>(e.kind)];
      if (e.kind == EditKind::Replace) {
        EXPECT_EQ(e.leaving, src->leaving);
      }
      if (e.kind == EditKind::Remove) continue;
      const Gaussian expect = quantize_roundtrip(src->value, p);
      EXPECT_EQ(std::memcmp(&e.value.position, &expect.position, sizeof(glm::vec3)), 0);
      EXPECT_EQ(e.value.rotation, expect.rotation);
      EXPECT_EQ(e.value.log_scale, expect.log_scale);
      EXPECT_EQ(e.value.opacity_logit, expect.opacity_logit);
      EXPECT_EQ(e.value.sh_dc, expect.sh_dc);
      EXPECT_EQ(e.value.sh_rest, expect.sh_rest);
      EXPECT_EQ(e.value.support, expect.support);
      expect_within_bounds(src->value, e.value, p);
    }
  }
}

TEST(CodecRoundtrip, ErrorBoundsHoldForRandomGaussians) {
  std::mt19937_64 rng(11);
  for (int degree = 0; degree <= 3; ++degree) {
    const CodecParams p = test_params(degree);
    for (int i = 0; i < 20000; ++i) {
      const Gaussian g = random_gaussian(rng, p, static_cast<std::uint64_t>(i));
      expect_within_bounds(g, quantize_roundtrip(g, p), p);
      if (HasFailure()) return;
    }
  }
}

// The rotation bound is tight enough to mean something: the worst error seen over many
// random rotations is within a factor of two of kRotationMaxError.
TEST(CodecRoundtrip, RotationBoundIsTight) {
  std::mt19937_64 rng(17);
  const CodecParams p = test_params(0);
  double worst = 0.0;
  for (int i = 0; i < 200000; ++i) {
    const Gaussian g = random_gaussian(rng, p, 1);
    const Gaussian q = quantize_roundtrip(g, p);
    double same = 0.0;
    double flip = 0.0;
    for (int c = 0; c < 4; ++c) {
      same = std::max(same, static_cast<double>(std::fabs(q.rotation[c] - g.rotation[c])));
      flip = std::max(flip, static_cast<double>(std::fabs(q.rotation[c] + g.rotation[c])));
    }
    worst = std::max(worst, std::min(same, flip));
  }
  EXPECT_LE(worst, kRotationMaxError);
  EXPECT_GT(worst, 0.5 * kRotationMaxError);
}

// Whole payload per SH0 Gaussian: the 15-byte record plus its share of the id, object and
// support columns stays at or below 16 bytes for consecutive ids, and for one id in five
// when support is uniform; varied support costs at most its 6-bit code.
TEST(CodecRoundtrip, RecordIsFifteenBytesAndAGaussianFitsSixteen) {
  EXPECT_EQ(record_bytes(0), 15u);
  EXPECT_EQ(record_bytes(3), 15u + 45u);
  const CodecParams p = test_params(0);
  std::mt19937_64 rng(3);
  auto payload = [&](std::uint64_t mean_gap, bool varied_support) {
    EditBatch b;
    std::uint64_t id = 1000;
    for (int i = 0; i < 10000; ++i) {
      id += mean_gap == 1 ? 1 : 1 + rng() % (2 * mean_gap - 1);
      Gaussian g = random_gaussian(rng, p, id);
      g.object = ObjectId{i < 4000 ? 2 : (i < 7000 ? -1 : 5)};
      if (!varied_support) g.support = 0;
      b.edits.push_back(Edit{EditKind::Insert, g.id, GaussianId{0}, g});
    }
    const auto raw = encode_edit_batch_raw(b, p);
    auto back = decode_edit_batch_raw(raw, p);
    EXPECT_TRUE(back.ok()) << back.message();
    return static_cast<double>(raw.size()) / 10000.0;
  };
  const double consecutive_uniform = payload(1, false);
  EXPECT_GE(consecutive_uniform, 15.0);
  EXPECT_LE(consecutive_uniform, 15.0 + 1.2 / 8.0);  // ~1 bit of id, runs for the rest
  const double consecutive_varied = payload(1, true);
  EXPECT_LE(consecutive_varied, 15.0 + (1.2 + kSupportCodeBits) / 8.0);
  EXPECT_LE(consecutive_varied, 16.0);
  const double one_in_five_uniform = payload(5, false);
  EXPECT_LE(one_in_five_uniform, 15.0 + 4.5 / 8.0);  // EG gaps of mean 5: ~4 bits
  EXPECT_LE(one_in_five_uniform, 16.0);
}

// Column codes at their extremes: ids next to 2^64 - 1, leaving ids jumping across the
// whole range, object ids alternating between the int32 ends, saturated support.
// Every uniform field inside its range decodes to lo + (hi - lo) * code / max with code =
// nearbyint((x - lo) / (hi - lo) * max): the quantiser as specified, whichever path the
// encoder takes (fields are quantised several at a time when a record's group is in range,
// one by one when a field of it is not). Values at the range ends and near the rounding
// midpoints, where another rounding rule would differ, are drawn on purpose.
TEST(CodecRoundtrip, InRangeFieldsTakeTheNearestCodeTiesToEvenOnEveryPath) {
  CodecParams p = test_params(3);
  p.box = {glm::vec3(0.0f), glm::vec3(float((1 << kPositionBits) - 1))};  // position step 1
  std::mt19937_64 rng(29);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  auto draw = [&](double lo, double hi, int top) {
    const double r = u(rng);
    if (r < 0.1) return float(lo);
    if (r < 0.2) return float(hi);
    if (r < 0.6) {  // near a midpoint between two codes
      const double k = std::floor(u(rng) * top);
      return float(lo + (hi - lo) * (k + 0.5) / top);
    }
    return float(lo + (hi - lo) * u(rng));
  };
  auto expected = [](double x, double lo, double hi, int top) {
    const double code = std::nearbyint((x - lo) / (hi - lo) * top);
    return float(lo + (hi - lo) * code / top);
  };
  const int pos_top = (1 << kPositionBits) - 1, scale_top = (1 << kLogScaleBits) - 1, dc_top = (1 << kDcBits) - 1;
  const int rest_top = (1 << kShRestBits) - 2;
  std::size_t checked = 0;
  for (int i = 0; i < 4000; ++i) {
    Gaussian g;
    for (int a = 0; a < 3; ++a) {
      g.position[a] = draw(p.box.min[a], p.box.max[a], pos_top);
      g.log_scale[a] = draw(p.log_scale_min, p.log_scale_max, scale_top);
      g.sh_dc[a] = draw(p.dc_min, p.dc_max, dc_top);
    }
    for (auto& c : g.sh_rest)
      for (int a = 0; a < 3; ++a) c[a] = draw(-p.sh_rest_abs_max, p.sh_rest_abs_max, rest_top);
    // One record in four has one field out of range or NaN: its group takes the one-by-one
    // path, and its other fields must come out the same.
    float* fields[] = {&g.position.x, &g.log_scale.z, &g.sh_dc.y, &g.sh_rest[7].x, &g.sh_rest[14].z};
    float* odd = i % 4 == 0 ? fields[(i / 4) % 5] : nullptr;
    if (odd) *odd = (i / 20) % 2 ? std::numeric_limits<float>::quiet_NaN() : 1e6f;
    const Gaussian out = quantize_roundtrip(g, p);
    auto check = [&](const float& in, float got, double lo, double hi, int top) {
      if (&in == odd) return;
      EXPECT_EQ(got, expected(in, lo, hi, top)) << "record " << i << ", value " << in;
      ++checked;
    };
    for (int a = 0; a < 3; ++a) {
      check(g.position[a], out.position[a], p.box.min[a], p.box.max[a], pos_top);
      check(g.log_scale[a], out.log_scale[a], p.log_scale_min, p.log_scale_max, scale_top);
      check(g.sh_dc[a], out.sh_dc[a], p.dc_min, p.dc_max, dc_top);
    }
    for (std::size_t k = 0; k < g.sh_rest.size(); ++k)
      for (int a = 0; a < 3; ++a)
        check(g.sh_rest[k][a], out.sh_rest[k][a], -p.sh_rest_abs_max, p.sh_rest_abs_max, rest_top);
  }
  EXPECT_GT(checked, 4000u * 50u);
}

TEST(CodecRoundtrip, ColumnExtremesRoundTripExactly) {
  const CodecParams p = test_params(0);
  EditBatch b;
  b.epoch = Epoch{~std::uint64_t{0}};
  const std::uint64_t max = ~std::uint64_t{0};
  const std::uint64_t ids[] = {0, 1, max - 3, max - 2, max};
  for (int i = 0; i < 5; ++i) {
    Edit e;
    e.kind = i % 2 ? EditKind::Replace : EditKind::Insert;
    e.id = GaussianId{ids[i]};
    e.leaving = GaussianId{i % 4 == 1 ? max : 0};
    e.value.object = ObjectId{i % 2 ? std::numeric_limits<std::int32_t>::min() : std::numeric_limits<std::int32_t>::max()};
    e.value.support = i % 2 ? 0u : 4'000'000'000u;
    b.edits.push_back(e);
  }
  b.edits.push_back(Edit{EditKind::Remove, GaussianId{max - 1}, GaussianId{0}, Gaussian{}});
  b.edits.push_back(Edit{EditKind::Remove, GaussianId{7}, GaussianId{0}, Gaussian{}});
  auto out = decode_edit_batch(encode_edit_batch(b, p), p);
  ASSERT_TRUE(out.ok()) << out.message();
  EXPECT_EQ(out->epoch, b.epoch);
  ASSERT_EQ(out->edits.size(), b.edits.size());
  for (const Edit& e : out->edits) {
    const auto src = std::find_if(b.edits.begin(), b.edits.end(), [&](const Edit& x) { return x.id == e.id; });
    ASSERT_NE(src, b.edits.end());
    EXPECT_EQ(e.kind, src->kind);
    if (e.kind == EditKind::Remove) continue;
    if (e.kind == EditKind::Replace) {
      EXPECT_EQ(e.leaving, src->leaving);
    }
    EXPECT_EQ(e.value.object, src->value.object);
    EXPECT_EQ(e.value.support, src->value.support == 0 ? 0u : kMaxSupport);
  }
}

TEST(CodecRoundtrip, OutOfRangeValuesClampAndCountNeverWrap) {
  const CodecParams p = test_params(1);
  Gaussian g;
  g.position = glm::vec3(1e6f, -1e6f, 0.0f);
  g.log_scale = glm::vec3(50.0f, -50.0f, 0.0f);
  g.sh_dc = glm::vec3(9.0f, -9.0f, 0.0f);
  g.sh_rest[0] = glm::vec3(100.0f, -100.0f, 0.0f);
  g.support = 10'000'000;
  CodecStats stats;
  std::uint8_t rec[record_bytes(1)];
  quantize_record(g, p, rec, &stats);
  EXPECT_EQ(stats.position_clamped, 2u);
  EXPECT_EQ(stats.log_scale_clamped, 2u);
  EXPECT_EQ(stats.dc_clamped, 2u);
  EXPECT_EQ(stats.sh_rest_clamped, 2u);
  EXPECT_EQ(stats.support_clamped, 0u);  // support travels in its own column
  EXPECT_EQ(stats.non_finite, 0u);
  EditBatch b;
  b.edits.push_back(Edit{EditKind::Insert, GaussianId{1}, GaussianId{0}, g});
  CodecStats batch_stats;
  (void)encode_edit_batch(b, p, &batch_stats);
  EXPECT_EQ(batch_stats.support_clamped, 1u);
  EXPECT_EQ(batch_stats.clamped_total(), 9u);
  const Gaussian q = quantize_roundtrip(g, p);
  EXPECT_FLOAT_EQ(q.position.x, p.box.max.x);
  EXPECT_FLOAT_EQ(q.position.y, p.box.min.y);
  EXPECT_FLOAT_EQ(q.log_scale.x, p.log_scale_max);
  EXPECT_FLOAT_EQ(q.log_scale.y, p.log_scale_min);
  EXPECT_FLOAT_EQ(q.sh_dc.x, p.dc_max);
  EXPECT_FLOAT_EQ(q.sh_dc.y, p.dc_min);
  EXPECT_FLOAT_EQ(q.sh_rest[0].x, p.sh_rest_abs_max);
  EXPECT_FLOAT_EQ(q.sh_rest[0].y, -p.sh_rest_abs_max);
  EXPECT_EQ(q.support, kMaxSupport);
}

TEST(CodecRoundtrip, NonFiniteValuesAreReplacedAndCounted) {
  const CodecParams p = test_params(0);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  Gaussian g;
  g.position = glm::vec3(nan, 0.0f, 0.0f);
  g.rotation = glm::vec4(nan, 0.0f, 0.0f, 0.0f);
  g.opacity_logit = nan;
  g.log_scale = glm::vec3(nan, -1.0f, -1.0f);
  CodecStats stats;
  std::uint8_t rec[16];
  quantize_record(g, p, rec, &stats);
  EXPECT_EQ(stats.non_finite, 4u);
  const Gaussian q = quantize_roundtrip(g, p);
  EXPECT_TRUE(std::isfinite(q.position.x));
  EXPECT_NEAR(q.position.x, 0.5f * (p.box.min.x + p.box.max.x), 1e-3f);
  EXPECT_EQ(q.rotation, glm::vec4(1.0f, 0.0f, 0.0f, 0.0f));  // identity is exact
  EXPECT_TRUE(std::isfinite(q.opacity_logit));
  // Infinite opacity logits are legitimate limits: decoded finite, a quarter step inside
  // 0 and 1 (within the half-step bound).
  const double quarter = 0.25 / ((1 << kOpacityBits) - 1);
  g = Gaussian{};
  g.opacity_logit = std::numeric_limits<float>::infinity();
  EXPECT_TRUE(std::isfinite(quantize_roundtrip(g, p).opacity_logit));
  EXPECT_NEAR(test::sigmoid(quantize_roundtrip(g, p).opacity_logit), 1.0 - quarter, 1e-6);
  g.opacity_logit = -std::numeric_limits<float>::infinity();
  EXPECT_NEAR(test::sigmoid(quantize_roundtrip(g, p).opacity_logit), quarter, 1e-6);
}

TEST(CodecRoundtrip, FitParamsCoverTheScene) {
  std::mt19937_64 rng(5);
  const CodecParams wide = test_params(3);
  std::vector<Gaussian> scene;
  for (int i = 0; i < 5000; ++i) scene.push_back(random_gaussian(rng, wide, static_cast<std::uint64_t>(i)));
  const CodecParams p = fit_codec_params(scene, 3);
  ASSERT_TRUE(validate_codec_params(p).ok());
  CodecStats stats;
  std::uint8_t rec[record_bytes(3)];
  for (const Gaussian& g : scene) quantize_record(g, p, rec, &stats);
  EXPECT_EQ(stats.position_clamped, 0u);
  // Only the 0.05 % tails per range may clamp.
  EXPECT_LE(stats.log_scale_clamped, 5000u * 3u / 1000u + 2u);
  EXPECT_LE(stats.dc_clamped, 5000u * 3u / 1000u + 2u);
  EXPECT_LE(stats.sh_rest_clamped, 5000u * 45u / 1000u + 2u);
  EXPECT_FALSE(validate_codec_params(CodecParams{CodecBox{glm::vec3(1.0f), glm::vec3(1.0f)}, 0}).ok());
  CodecParams bad;
  bad.sh_degree = 4;
  EXPECT_FALSE(validate_codec_params(bad).ok());
}

TEST(CodecRoundtrip, FitParamsTakeTheExactQuantiles) {
  // fit_codec_params finds the SH rest quantile by counting float bits and the log-scale
  // range by a scan; both must be what selecting over the collected values gives. Zeros,
  // -0, ties, NaN and Inf (left out), tiny and huge values, at every SH degree.
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int degree = 1; degree <= 3; ++degree) {
    for (int round = 0; round < 3; ++round) {
      std::vector<Gaussian> scene(round == 0 ? 1 : 3000);
      for (Gaussian& g : scene) {
        g.log_scale = {u(rng) * 4.0f, u(rng) * 4.0f, u(rng) * 4.0f};
        for (int k = 0; k < sh_rest_count(degree); ++k)
          for (int c = 0; c < 3; ++c) {
            float x = u(rng) * (round == 2 ? 1e-30f : 0.5f);
            switch (rng() % 16) {
              case 0: x = 0.0f; break;
              case 1: x = -0.0f; break;
              case 2: x = 0.25f; break;  // ties
              case 3: x = std::numeric_limits<float>::quiet_NaN(); break;
              case 4: x = -std::numeric_limits<float>::infinity(); break;
              case 5: x = 3e38f; break;
              default: break;
            }
            g.sh_rest[static_cast<std::size_t>(k)][c] = x;
          }
      }
      scene[0].log_scale.y = std::numeric_limits<float>::quiet_NaN();
      std::vector<float> abs_rest, scales;
      for (const Gaussian& g : scene) {
        for (int k = 0; k < sh_rest_count(degree); ++k)
          for (int c = 0; c < 3; ++c)
            if (std::isfinite(g.sh_rest[static_cast<std::size_t>(k)][c]))
              abs_rest.push_back(std::fabs(g.sh_rest[static_cast<std::size_t>(k)][c]));
        for (int a = 0; a < 3; ++a)
          if (std::isfinite(g.log_scale[a])) scales.push_back(g.log_scale[a]);
      }
      const CodecParams p = fit_codec_params(scene, degree);
      if (abs_rest.empty()) {
        EXPECT_EQ(p.sh_rest_abs_max, CodecParams{}.sh_rest_abs_max);
      } else {
        const auto k = static_cast<std::size_t>(0.9995 * static_cast<double>(abs_rest.size() - 1));
        std::nth_element(abs_rest.begin(), abs_rest.begin() + static_cast<std::ptrdiff_t>(k), abs_rest.end());
        EXPECT_EQ(p.sh_rest_abs_max, std::max(abs_rest[k], 1e-3f)) << "degree " << degree << ", round " << round;
      }
      const auto [lo, hi] = std::minmax_element(scales.begin(), scales.end());
      const bool narrow = !(*hi - *lo >= 1.0f);
      const float mid = 0.5f * (*lo + *hi);
      EXPECT_EQ(p.log_scale_min, narrow ? mid - 0.5f : *lo);
      EXPECT_EQ(p.log_scale_max, narrow ? mid + 0.5f : *hi);
    }
  }
}

TEST(CodecHostile, TruncatedAndCorruptPayloadsAreRejected) {
  std::mt19937_64 rng(13);
  const CodecParams p = test_params(1);
  const EditBatch in = random_batch(rng, p, 40);
  const auto raw = encode_edit_batch_raw(in, p);
  ASSERT_TRUE(decode_edit_batch_raw(raw, p).ok());
  for (std::size_t len = 0; len < raw.size(); ++len) {
    auto r = decode_edit_batch_raw(std::span(raw.data(), len), p);
    EXPECT_FALSE(r.ok()) << "prefix of " << len << " bytes accepted";
    if (!r.ok()) {
      EXPECT_NE(r.message().find("edit batch"), std::string::npos);
    }
  }
  // Trailing garbage, wrong magic, version or SH degree.
  auto extra = raw;
  extra.push_back(0);
  EXPECT_FALSE(decode_edit_batch_raw(extra, p).ok());
  auto bad = raw;
  bad[0] = 'X';
  EXPECT_FALSE(decode_edit_batch_raw(bad, p).ok());
  bad = raw;
  bad[4] = 99;
  EXPECT_FALSE(decode_edit_batch_raw(bad, p).ok());
  CodecParams other = p;
  other.sh_degree = 2;
  EXPECT_FALSE(decode_edit_batch_raw(raw, other).ok());
  // Random byte flips: any result is fine as long as it does not crash.
  for (int i = 0; i < 2000; ++i) {
    auto m = raw;
    const int flips = 1 + static_cast<int>(rng() % 4);
    for (int f = 0; f < flips; ++f) m[rng() % m.size()] = static_cast<std::uint8_t>(rng());
    (void)decode_edit_batch_raw(m, p);
  }
}

TEST(CodecHostile, LyingCountsAndSizesAreRejectedBeforeAllocating) {
  const CodecParams p = test_params(0);
  // Header claiming 2^60 removes in a 20-byte payload.
  std::vector<std::uint8_t> m = {'G', 'A', 'E', 'B', kCodecVersion, 0, 0};
  for (int i = 0; i < 8; ++i) m.push_back(0xFF);
  m.push_back(0x0F);
  m.push_back(0);
  m.push_back(0);
  m.push_back(0);
  auto r = decode_edit_batch_raw(m, p);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("count"), std::string::npos) << r.message();
  // 2^21 one-byte removes: a payload that size could hold them, the batch limit cannot.
  m = {'G', 'A', 'E', 'B', kCodecVersion, 0, 0, 0x80, 0x80, 0x80, 0x01, 0, 0, 0};
  m.resize(m.size() + (std::size_t{1} << 21), 1);
  r = decode_edit_batch_raw(m, p);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("limit"), std::string::npos) << r.message();
  // Value edits that need more record bytes than present.
  m = {'G', 'A', 'E', 'B', kCodecVersion, 0, 0, 0, 0, 0, 5, 1, 2, 3, 4, 5};
  EXPECT_FALSE(decode_edit_batch_raw(m, p).ok());
  // A zstd frame that declares a 1 GiB payload.
  std::vector<std::uint8_t> big(1 << 20, 0);
  std::vector<std::uint8_t> z(ZSTD_compressBound(big.size()));
  z.resize(ZSTD_compress(z.data(), z.size(), big.data(), big.size(), 1));
  EXPECT_FALSE(decode_edit_batch(z, p).ok());  // valid frame, not a batch
  std::vector<std::uint8_t> fake = {0x28, 0xB5, 0x2F, 0xFD, 0xA4, 0x00, 0x00, 0x00, 0x40, 0x00, 0x00};
  auto rz = decode_edit_batch(fake, p);
  ASSERT_FALSE(rz.ok());
  EXPECT_FALSE(decode_edit_batch(std::span<const std::uint8_t>(), p).ok());
  // Overlong varint (11 continuation bytes) in the epoch.
  m = {'G', 'A', 'E', 'B', kCodecVersion, 0};
  for (int i = 0; i < 11; ++i) m.push_back(0x80);
  EXPECT_FALSE(decode_edit_batch_raw(m, p).ok());
}

// Bit-column lies: runs that cover more or fewer edits than the header declares, a
// support code beyond 6 bits, non-zero padding and an older version are all rejected
// with the byte offset named.
TEST(CodecHostile, BitColumnLiesAreRejectedWithAnOffset) {
  const CodecParams p = test_params(0);
  // One insert: id 1, object 3, support 0. Header: magic, version, degree, epoch 0,
  // counts 0 0 0 1 = 11 bytes; the bit columns follow, then the record.
  EditBatch b;
  Gaussian g;
  g.object = ObjectId{3};
  b.edits.push_back(Edit{EditKind::Insert, GaussianId{1}, GaussianId{0}, g});
  const auto raw = encode_edit_batch_raw(b, p);
  ASSERT_TRUE(decode_edit_batch_raw(raw, p).ok());
  ASSERT_EQ(raw.size(), 11u + 5u + record_bytes(0)) << "header, 5 bytes of bit columns, one record";
  using Fields = std::vector<std::pair<std::uint64_t, int>>;  // (value, bits), LSB-first
  auto payload = [&](const Fields& fields) {
    std::vector<std::uint8_t> m(raw.begin(), raw.begin() + 11);
    std::uint64_t acc = 0;
    int fill = 0;
    for (auto [v, n] : fields) {
      for (int i = 0; i < n; ++i) {
        acc |= ((v >> i) & 1u) << fill;
        if (++fill == 8) {
          m.push_back(static_cast<std::uint8_t>(acc));
          acc = 0;
          fill = 0;
        }
      }
    }
    if (fill) m.push_back(static_cast<std::uint8_t>(acc));
    m.insert(m.end(), raw.end() - static_cast<std::ptrdiff_t>(record_bytes(0)), raw.end());
    return m;
  };
  auto cat = [](Fields a, const Fields& c) {
    a.insert(a.end(), c.begin(), c.end());
    return a;
  };
  // EG_k(v): x = v + 2^k, n = top bit of x: n - k zeros, a one, x's n low bits.
  const Fields ids = {{0, 6}, {0, 1}, {1, 1}, {0, 1}};           // k = 0, EG_0(1)
  const Fields object_head = {{1, 1}, {0, 6}, {3, 6}};           // EG_0(runs - 1 = 0), k_len 0, k_obj 3
  const Fields object_run = {{1, 1}, {1, 1}, {6, 3}};            // EG_0(0), EG_3(zigzag 3 = 6)
  const Fields support_packed = {{0, 1}, {0, 6}};                // mode 0, code 0
  const Fields honest = cat(cat(cat(ids, object_head), object_run), support_packed);
  {
    auto r = decode_edit_batch_raw(payload(honest), p);
    ASSERT_TRUE(r.ok()) << r.message();
    EXPECT_EQ(r->edits[0].id, GaussianId{1});
    EXPECT_EQ(r->edits[0].value.object, ObjectId{3});
  }
  auto expect_reject = [&](const Fields& fields, const char* what) {
    auto r = decode_edit_batch_raw(payload(fields), p);
    ASSERT_FALSE(r.ok()) << what;
    EXPECT_NE(r.message().find("byte "), std::string::npos) << r.message();
    EXPECT_NE(r.message().find(what), std::string::npos) << r.message();
  };
  // Two runs for one value edit: EG_0(1) = 0, 1, 0.
  expect_reject(cat(cat(cat(ids, {{0, 1}, {1, 1}, {0, 1}, {0, 6}, {3, 6}}), object_run), support_packed),
                "runs than value edits");
  // A run of length 2 for one value edit: EG_0(1) as the length.
  expect_reject(cat(cat(cat(ids, object_head), {{0, 1}, {1, 1}, {0, 1}, {1, 1}, {6, 3}}), support_packed),
                "passes the last");
  // Support runs whose code is 64: EG_7(zigzag 64 = 128): x = 256, n = 8: 0, 1, 8 zeros.
  expect_reject(cat(cat(cat(ids, object_head), object_run),
                    {{1, 1}, {1, 1}, {0, 6}, {7, 6}, {1, 1}, {0, 1}, {1, 1}, {0, 8}}),
                "support code");
  // Non-zero padding after an honest stream (34 bits, then a stray one).
  expect_reject(cat(honest, {{1, 1}}), "padding");
  // Version 1 payloads are no longer understood.
  auto old = raw;
  old[4] = 1;
  auto r = decode_edit_batch_raw(old, p);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("version"), std::string::npos);
}

TEST(CodecHostile, EmptyBatchRoundTrips) {
  const CodecParams p = test_params(2);
  EditBatch b;
  b.epoch = Epoch{42};
  auto r = decode_edit_batch(encode_edit_batch(b, p), p);
  ASSERT_TRUE(r.ok()) << r.message();
  EXPECT_EQ(r->epoch, Epoch{42});
  EXPECT_TRUE(r->edits.empty());
}

}  // namespace
}  // namespace gauss
