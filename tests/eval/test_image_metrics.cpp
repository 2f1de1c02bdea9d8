// Image metrics (PSNR, SSIM, FLIP): exact values where a closed form exists, FLIP against
// an independent NumPy implementation (tests/eval/data/flip_reference.py, which prints
// every FLIP value expected here), the mask contract (a pixel outside the mask never
// changes a result; a rectangular mask equals the crop) and every error.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/eval/image_metrics.h"

namespace gauss::eval {
namespace {

struct Rgb {
  std::uint8_t r, g, b;
};

// An owned RGBA8 image with a view.
struct Image {
  std::uint32_t width{0}, height{0};
  std::vector<std::uint8_t> rgba;

  Image(std::uint32_t w, std::uint32_t h, Rgb fill = {0, 0, 0})
      : width(w), height(h), rgba(std::size_t{w} * h * 4) {
    for (std::uint32_t y = 0; y < h; ++y)
      for (std::uint32_t x = 0; x < w; ++x) set(x, y, fill);
  }
  void set(std::uint32_t x, std::uint32_t y, Rgb c) {
    const std::size_t o = (std::size_t{y} * width + x) * 4;
    rgba[o] = c.r;
    rgba[o + 1] = c.g;
    rgba[o + 2] = c.b;
    rgba[o + 3] = 255;
  }
  Rgb get(std::uint32_t x, std::uint32_t y) const {
    const std::size_t o = (std::size_t{y} * width + x) * 4;
    return {rgba[o], rgba[o + 1], rgba[o + 2]};
  }
  ImageView view() const { return {width, height, rgba}; }
  Image crop(std::uint32_t x0, std::uint32_t y0, std::uint32_t w, std::uint32_t h) const {
    Image out(w, h);
    for (std::uint32_t y = 0; y < h; ++y)
      for (std::uint32_t x = 0; x < w; ++x) out.set(x, y, get(x0 + x, y0 + y));
    return out;
  }
};

// Deterministic noise (a fixed LCG), so every run sees the same images.
struct Lcg {
  std::uint32_t state;
  std::uint8_t next() {
    state = state * 1664525u + 1013904223u;
    return static_cast<std::uint8_t>(state >> 24);
  }
};

Image noise_image(std::uint32_t w, std::uint32_t h, std::uint32_t seed) {
  Image img(w, h);
  Lcg lcg{seed};
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) img.set(x, y, {lcg.next(), lcg.next(), lcg.next()});
  return img;
}

// `base` plus bounded noise of amplitude `amp` (clamped to [0, 255]).
Image perturbed(const Image& base, int amp, std::uint32_t seed) {
  Image out = base;
  Lcg lcg{seed};
  const auto jitter = [&](std::uint8_t v) {
    const int d = static_cast<int>(lcg.next() % (2 * amp + 1)) - amp;
    const int r = v + d;
    return static_cast<std::uint8_t>(r < 0 ? 0 : r > 255 ? 255 : r);
  };
  for (std::uint32_t y = 0; y < base.height; ++y)
    for (std::uint32_t x = 0; x < base.width; ++x) {
      const Rgb c = base.get(x, y);
      out.set(x, y, {jitter(c.r), jitter(c.g), jitter(c.b)});
    }
  return out;
}

// A smooth image with an edge and some structure (something for SSIM and FLIP's features).
Image structured_image(std::uint32_t w, std::uint32_t h) {
  Image img(w, h);
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x)
      img.set(x, y, {static_cast<std::uint8_t>(4 * x + 2 * y),
                     static_cast<std::uint8_t>(x >= w / 2 ? 200 : 60),
                     static_cast<std::uint8_t>((x * y) % 97 + 80)});
  return img;
}

// The pattern pair of tests/eval/data/flip_reference.py (pattern_pair), 24x20.
void pattern_pair(Image& ref, Image& test) {
  ref = Image(24, 20);
  test = Image(24, 20);
  for (std::uint32_t y = 0; y < 20; ++y)
    for (std::uint32_t x = 0; x < 24; ++x) {
      ref.set(x, y, {static_cast<std::uint8_t>(8 * x + 2 * y),
                     static_cast<std::uint8_t>(x >= 12 ? 230 : 40),
                     static_cast<std::uint8_t>((7 * x * y) % 256)});
      const std::uint32_t r = 8 * x + 2 * y + ((x >= 4 && x < 10 && y >= 4 && y < 10) ? 30 : 0);
      test.set(x, y, {static_cast<std::uint8_t>(r), static_cast<std::uint8_t>(x >= 13 ? 230 : 40),
                      static_cast<std::uint8_t>((7 * x * y + 13 * ((x + y) % 3)) % 256)});
    }
}

Mask rect_mask(std::uint32_t w, std::uint32_t h, std::uint32_t x0, std::uint32_t y0,
               std::uint32_t rw, std::uint32_t rh) {
  Mask m(std::size_t{w} * h, 0);
  for (std::uint32_t y = y0; y < y0 + rh; ++y)
    for (std::uint32_t x = x0; x < x0 + rw; ++x) m[std::size_t{y} * w + x] = 1;
  return m;
}

// A disc: not a rectangle, with ragged rows and whole rows outside it.
Mask disc_mask(std::uint32_t w, std::uint32_t h, double cx, double cy, double radius) {
  Mask m(std::size_t{w} * h, 0);
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x)
      if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= radius * radius)
        m[std::size_t{y} * w + x] = 1;
  return m;
}

// Overwrites every pixel outside `mask` of `img` with noise.
void scramble_outside(Image& img, const Mask& mask, std::uint32_t seed) {
  Lcg lcg{seed};
  for (std::uint32_t y = 0; y < img.height; ++y)
    for (std::uint32_t x = 0; x < img.width; ++x)
      if (mask[std::size_t{y} * img.width + x] == 0)
        img.set(x, y, {lcg.next(), lcg.next(), lcg.next()});
}

double value(const Expected<double>& e) {
  EXPECT_TRUE(e.ok()) << e.message();
  return e.ok() ? *e : std::numeric_limits<double>::quiet_NaN();
}

// ---------------------------------------------------------------- PSNR

TEST(Psnr, IdenticalImagesAreInfinite) {
  const Image a = noise_image(16, 12, 1);
  const double p = value(psnr(a.view(), a.view()));
  EXPECT_TRUE(std::isinf(p) && p > 0) << p;
}

TEST(Psnr, UniformOffsetIsClosedForm) {
  // Every channel off by d: MSE = d^2, PSNR = 20 log10(255 / d).
  const Image a(8, 8, {100, 120, 140});
  const Image b(8, 8, {105, 125, 145});
  EXPECT_NEAR(value(psnr(a.view(), b.view())), 20.0 * std::log10(255.0 / 5.0), 1e-12);
  // One channel off by 9: MSE = 81 / 3 = 27.
  const Image c(8, 8, {100, 129, 140});
  EXPECT_NEAR(value(psnr(a.view(), c.view())), 10.0 * std::log10(255.0 * 255.0 / 27.0), 1e-12);
  // Symmetric, and a smaller offset scores higher.
  EXPECT_EQ(value(psnr(b.view(), a.view())), value(psnr(a.view(), b.view())));
  const Image d(8, 8, {101, 121, 141});
  EXPECT_GT(value(psnr(a.view(), d.view())), value(psnr(a.view(), b.view())));
}

TEST(Psnr, CountsOnlyMaskedPixels) {
  // Left half identical, right half off by 10 everywhere: over the left half +inf, over the
  // right half exactly 20 log10(25.5), over all pixels MSE 50.
  Image a(10, 6, {50, 60, 70});
  Image b = a;
  for (std::uint32_t y = 0; y < 6; ++y)
    for (std::uint32_t x = 5; x < 10; ++x) b.set(x, y, {60, 70, 80});
  EXPECT_TRUE(std::isinf(value(psnr(a.view(), b.view(), rect_mask(10, 6, 0, 0, 5, 6)))));
  EXPECT_NEAR(value(psnr(a.view(), b.view(), rect_mask(10, 6, 5, 0, 5, 6))),
              20.0 * std::log10(25.5), 1e-12);
  EXPECT_NEAR(value(psnr(a.view(), b.view())), 10.0 * std::log10(255.0 * 255.0 / 50.0), 1e-12);
}

// ---------------------------------------------------------------- SSIM

TEST(MeanAbsDifference, ClosedFormOverTheMaskedPixels) {
  Image a(4, 2, {10, 20, 30}), b(4, 2, {10, 20, 30});
  b.set(0, 0, {13, 20, 30});  // 3 levels in one channel
  b.set(3, 1, {0, 0, 0});     // 10 + 20 + 30 levels
  auto all = mean_abs_difference(a.view(), b.view());
  ASSERT_TRUE(all.ok()) << all.message();
  EXPECT_DOUBLE_EQ(*all, (3.0 + 60.0) / (3.0 * 8.0));
  Mask first(8, 0);
  first[0] = 1;
  auto one = mean_abs_difference(a.view(), b.view(), first);
  ASSERT_TRUE(one.ok());
  EXPECT_DOUBLE_EQ(*one, 1.0);
  EXPECT_FALSE(mean_abs_difference(a.view(), Image(4, 3).view()).ok()) << "sizes differ";
}

TEST(FrameChange, MeanAndMaxOverConsecutivePairs) {
  FrameChange change;
  EXPECT_EQ(change.mean(), 0.0) << "no pair yet";
  const Image f0(2, 2, {0, 0, 0}), f1(2, 2, {3, 3, 3}), f2(2, 2, {3, 3, 3});
  ASSERT_TRUE(change.add(f0.view()).ok());
  ASSERT_TRUE(change.add(f1.view()).ok());  // 3 levels everywhere
  ASSERT_TRUE(change.add(f2.view()).ok());  // unchanged
  EXPECT_EQ(change.pairs(), 2u);
  EXPECT_DOUBLE_EQ(change.mean(), 1.5);
  EXPECT_DOUBLE_EQ(change.max(), 3.0);
  EXPECT_FALSE(change.add(Image(3, 2).view()).ok()) << "a frame of another size";
}

TEST(Ssim, IdenticalImagesAreExactlyOne) {
  const Image a = noise_image(20, 17, 2);
  EXPECT_EQ(value(ssim(a.view(), a.view())), 1.0);
  const Image s = structured_image(32, 24);
  EXPECT_EQ(value(ssim(s.view(), s.view())), 1.0);
  EXPECT_EQ(value(ssim(s.view(), s.view(), disc_mask(32, 24, 15.5, 11.5, 9.0))), 1.0);
}

TEST(Ssim, ConstantPairByHand) {
  // Constant greys 100 and 110: every window has zero variance, so the structure term is
  // C2 / C2 = 1 and SSIM = (2 * 100 * 110 + C1) / (100^2 + 110^2 + C1) with
  // C1 = (0.01 * 255)^2 = 6.5025: 22006.5025 / 22106.5025 = 1 - 100 / 22106.5025 = 0.9954764441...
  const Image a(16, 16, {100, 100, 100});
  const Image b(16, 16, {110, 110, 110});
  const double expected = 22006.5025 / 22106.5025;
  EXPECT_NEAR(expected, 0.9954764441, 1e-10);
  EXPECT_NEAR(value(ssim(a.view(), b.view())), expected, 1e-12);
}

TEST(Ssim, SymmetricAndBelowOneForNoise) {
  const Image a = structured_image(32, 24);
  const Image b = perturbed(a, 12, 3);
  const double ab = value(ssim(a.view(), b.view()));
  EXPECT_EQ(ab, value(ssim(b.view(), a.view())));
  EXPECT_LT(ab, 1.0);
  EXPECT_GT(ab, 0.0);
  // More noise, lower SSIM.
  const Image c = perturbed(a, 40, 3);
  EXPECT_LT(value(ssim(a.view(), c.view())), ab);
}

TEST(Ssim, WindowIsElevenPixelsWide) {
  // One pixel changed at (16, 16) of a constant image: the map is exactly 1 at every centre
  // whose 11x11 window misses it (Chebyshev distance > 5) and below 1 where it is seen.
  const Image a(33, 33, {90, 90, 90});
  Image b = a;
  b.set(16, 16, {190, 190, 190});
  auto map = ssim_map(a.view(), b.view());
  ASSERT_TRUE(map.ok()) << map.message();
  for (std::uint32_t y = 0; y < 33; ++y)
    for (std::uint32_t x = 0; x < 33; ++x) {
      const int d =
          std::max(std::abs(static_cast<int>(x) - 16), std::abs(static_cast<int>(y) - 16));
      const float v = (*map)[std::size_t{y} * 33 + x];
      if (d > 5) {
        EXPECT_EQ(v, 1.0f) << x << "," << y;
      } else {
        EXPECT_LT(v, 1.0f) << x << "," << y;
      }
    }
}

// ---------------------------------------------------------------- FLIP

TEST(Flip, IdenticalImagesAreZero) {
  Image ref(1, 1), test(1, 1);
  pattern_pair(ref, test);
  EXPECT_EQ(value(flip(ref.view(), ref.view())), 0.0);
  const Image n = noise_image(20, 20, 4);
  EXPECT_EQ(value(flip(n.view(), n.view())), 0.0);
  auto map = flip_map(n.view(), n.view());
  ASSERT_TRUE(map.ok()) << map.message();
  for (float v : *map) EXPECT_EQ(v, 0.0f);
}

TEST(Flip, UniformColourDifferenceIsTheColourTermOnly) {
  // Uniform images: the CSF filters (normalised, edges repeated) leave them unchanged and
  // the edge and point detectors (weights summing to 0) give 0, so FLIP is the colour term
  // alone: redistribute(HyAB(Hunt(Lab(ref)), Hunt(Lab(test)))^0.7). Expected values from
  // tests/eval/data/flip_reference.py (uniform_colour_error), which computes that chain in
  // NumPy without any filtering.
  const Image red(16, 16, {200, 50, 50});
  const Image red2(16, 16, {180, 70, 40});
  EXPECT_NEAR(value(flip(red.view(), red2.view())), 0.2486262198, 1e-6);
  const Image grey(16, 16, {128, 128, 128});
  const Image grey2(16, 16, {138, 138, 138});
  EXPECT_NEAR(value(flip(grey.view(), grey2.view())), 0.1489854931, 1e-6);
}

TEST(Flip, AgreesWithTheIndependentReferenceOnAPattern) {
  // Edges, a shifted edge, a brightened square, fine structure: colour and feature terms
  // both count. Values from tests/eval/data/flip_reference.py (direct 2-D kernels).
  Image ref(1, 1), test(1, 1);
  pattern_pair(ref, test);
  EXPECT_NEAR(value(flip(ref.view(), test.view())), 0.2615676733, 1e-6);
  auto map = flip_map(ref.view(), test.view());
  ASSERT_TRUE(map.ok()) << map.message();
  EXPECT_NEAR((*map)[6 * 24 + 6], 0.3269872276, 1e-6);
  EXPECT_NEAR((*map)[3 * 24 + 12], 0.7582622074, 1e-6);
  EXPECT_NEAR((*map)[0], 0.0679592450, 1e-6);
}

TEST(Flip, InUnitRangeAndGrowsWithTheDifference) {
  const Image grey(16, 16, {128, 128, 128});
  double last = 0.0;
  for (std::uint8_t v : {133, 148, 178, 228, 255}) {
    const double f = value(flip(grey.view(), Image(16, 16, {v, v, v}).view()));
    EXPECT_GT(f, last) << int{v};
    EXPECT_LE(f, 1.0);
    last = f;
  }
  const Image a = noise_image(24, 24, 5);
  const Image b = noise_image(24, 24, 6);
  auto map = flip_map(a.view(), b.view());
  ASSERT_TRUE(map.ok()) << map.message();
  for (float v : *map) {
    EXPECT_GE(v, 0.0f);
    EXPECT_LE(v, 1.0f);
  }
  const Image s = structured_image(32, 24);
  const double small = value(flip(s.view(), perturbed(s, 6, 7).view()));
  const double large = value(flip(s.view(), perturbed(s, 40, 7).view()));
  EXPECT_GT(small, 0.0);
  EXPECT_GT(large, small);
  EXPECT_LE(large, 1.0);
}

// ---------------------------------------------------------------- masks

TEST(Masks, PixelsOutsideTheMaskNeverChangeAResult) {
  const Image ref = structured_image(32, 24);
  const Image test = perturbed(ref, 20, 8);
  for (const Mask& mask : {disc_mask(32, 24, 14.0, 12.0, 8.5), rect_mask(32, 24, 3, 5, 17, 11)}) {
    Image ref2 = ref, test2 = test;
    scramble_outside(ref2, mask, 9);
    scramble_outside(test2, mask, 10);
    auto s1 = compare(ref.view(), test.view(), mask);
    auto s2 = compare(ref2.view(), test2.view(), mask);
    ASSERT_TRUE(s1.ok() && s2.ok());
    EXPECT_EQ(s1->psnr_db, s2->psnr_db);
    EXPECT_EQ(s1->ssim, s2->ssim);
    EXPECT_EQ(s1->flip, s2->flip);
    EXPECT_EQ(s1->pixels, s2->pixels);
    EXPECT_EQ(s1->differing_pixels, s2->differing_pixels);
    // ... while the same change inside the mask does change every metric.
    Image test3 = test;
    for (std::uint32_t x = 0; x < 32; ++x) test3.set(x, 12, {255, 0, 255});
    auto s3 = compare(ref.view(), test3.view(), mask);
    ASSERT_TRUE(s3.ok());
    EXPECT_NE(s1->psnr_db, s3->psnr_db);
    EXPECT_NE(s1->ssim, s3->ssim);
    EXPECT_NE(s1->flip, s3->flip);
    // The masked maps hold 0 outside the mask.
    auto fm = flip_map(ref.view(), test.view(), mask);
    auto sm = ssim_map(ref.view(), test.view(), mask);
    ASSERT_TRUE(fm.ok() && sm.ok());
    for (std::size_t i = 0; i < mask.size(); ++i)
      if (mask[i] == 0) {
        EXPECT_TRUE((*fm)[i] == 0.0f && (*sm)[i] == 0.0f) << i;
      }
  }
}

TEST(Masks, RectangularMaskEqualsTheCrop) {
  const Image ref = structured_image(40, 30);
  const Image test = perturbed(ref, 25, 11);
  const Mask mask = rect_mask(40, 30, 7, 4, 21, 15);
  const Image rc = ref.crop(7, 4, 21, 15), tc = test.crop(7, 4, 21, 15);
  EXPECT_EQ(value(psnr(ref.view(), test.view(), mask)), value(psnr(rc.view(), tc.view())));
  EXPECT_EQ(value(ssim(ref.view(), test.view(), mask)), value(ssim(rc.view(), tc.view())));
  EXPECT_EQ(value(flip(ref.view(), test.view(), mask)), value(flip(rc.view(), tc.view())));
}

TEST(Masks, FullMaskEqualsNoMask) {
  Image ref(1, 1), test(1, 1);
  pattern_pair(ref, test);
  const Mask all(24 * 20, 1);
  auto a = compare(ref.view(), test.view());
  auto b = compare(ref.view(), test.view(), all);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->psnr_db, b->psnr_db);
  EXPECT_EQ(a->ssim, b->ssim);
  EXPECT_EQ(a->flip, b->flip);
  // Any non-zero mask value counts.
  EXPECT_EQ(value(flip(ref.view(), test.view(), Mask(24 * 20, 255))), a->flip);
}

TEST(Compare, MatchesTheSingleMetricsAndCountsPixels) {
  Image ref(12, 10, {10, 20, 30});
  Image test = ref;
  test.set(1, 1, {11, 20, 30});
  test.set(5, 5, {10, 20, 31});
  test.set(9, 8, {0, 0, 0});
  const Mask mask = rect_mask(12, 10, 0, 0, 12, 6);  // rows 0-5: holds two of the three
  auto s = compare(ref.view(), test.view(), mask);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(s->pixels, 72u);
  EXPECT_EQ(s->differing_pixels, 2u);
  EXPECT_EQ(s->psnr_db, value(psnr(ref.view(), test.view(), mask)));
  EXPECT_EQ(s->ssim, value(ssim(ref.view(), test.view(), mask)));
  EXPECT_EQ(s->flip, value(flip(ref.view(), test.view(), mask)));
  // Alpha is ignored everywhere.
  Image alpha = ref;
  for (std::size_t i = 3; i < alpha.rgba.size(); i += 4) alpha.rgba[i] = 7;
  auto same = compare(ref.view(), alpha.view());
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(same->differing_pixels, 0u);
  EXPECT_TRUE(std::isinf(same->psnr_db));
  EXPECT_EQ(same->ssim, 1.0);
  EXPECT_EQ(same->flip, 0.0);
}

// ---------------------------------------------------------------- errors

// Runs every entry point on the inputs; each must fail with a message containing `needle`.
void expect_all_fail(const ImageView& a, const ImageView& b, const Mask& mask,
                     const std::string& needle) {
  const auto check = [&](const std::string& what, bool ok, const std::string& message) {
    EXPECT_FALSE(ok) << what;
    if (!ok) {
      EXPECT_NE(message.find(needle), std::string::npos) << what << ": " << message;
      EXPECT_EQ(message.rfind(what + ": ", 0), 0u) << message;
    }
  };
  {
    auto r = psnr(a, b, mask);
    check("psnr", r.ok(), r.ok() ? "" : r.message());
  }
  {
    auto r = ssim(a, b, mask);
    check("ssim", r.ok(), r.ok() ? "" : r.message());
  }
  {
    auto r = flip(a, b, mask);
    check("flip", r.ok(), r.ok() ? "" : r.message());
  }
  {
    auto r = compare(a, b, mask);
    check("compare", r.ok(), r.ok() ? "" : r.message());
  }
  {
    auto r = ssim_map(a, b, mask);
    check("ssim_map", r.ok(), r.ok() ? "" : r.message());
  }
  {
    auto r = flip_map(a, b, mask);
    check("flip_map", r.ok(), r.ok() ? "" : r.message());
  }
  if (mask.empty()) {
    auto r = flip_map(a, b);
    check("flip_map", r.ok(), r.ok() ? "" : r.message());
  }
}

TEST(Errors, SizesDiffer) {
  const Image a(8, 6), b(6, 8), c(8, 5);
  expect_all_fail(a.view(), b.view(), {}, "image sizes differ: 8x6 and 6x8");
  expect_all_fail(a.view(), c.view(), {}, "image sizes differ: 8x6 and 8x5");
}

TEST(Errors, EmptyImage) {
  const Image a(0, 4), b(0, 4);
  expect_all_fail(a.view(), b.view(), {}, "empty image (0x4)");
}

TEST(Errors, SpanShorterThanTheImage) {
  const Image a(4, 4), b(4, 4);
  const std::span<const std::uint8_t> short_span(a.rgba.data(), 63);
  expect_all_fail(ImageView{4, 4, short_span}, b.view(), {},
                  "first image holds 63 bytes, 4x4 RGBA8 needs 64");
  expect_all_fail(a.view(), ImageView{4, 4, short_span}, {},
                  "second image holds 63 bytes, 4x4 RGBA8 needs 64");
  // A longer span is fine (only the first width * height * 4 bytes are read).
  std::vector<std::uint8_t> longer(a.rgba);
  longer.resize(100, 9);
  EXPECT_TRUE(flip(ImageView{4, 4, longer}, b.view()).ok());
}

TEST(Errors, MaskOfTheWrongSize) {
  const Image a(4, 4), b(4, 4);
  expect_all_fail(a.view(), b.view(), Mask(15, 1), "mask has 15 entries, a 4x4 image needs 16");
  expect_all_fail(a.view(), b.view(), Mask(17, 1), "mask has 17 entries, a 4x4 image needs 16");
}

TEST(Errors, MaskSelectsNoPixel) {
  const Image a(4, 4), b(4, 4);
  expect_all_fail(a.view(), b.view(), Mask(16, 0), "the mask selects no pixel");
}

}  // namespace
}  // namespace gauss::eval
