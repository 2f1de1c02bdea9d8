// First golden test: shaders/test_pattern.comp renders a known pattern into the
// offscreen colour target; the readback must equal golden/compute_pattern.png AND the
// same pattern computed here on the CPU (so the golden itself is verified), and the
// per-tile sums written to a storage buffer must match too. CTest also runs this with
// LP_NATIVE_VECTOR_WIDTH=128 / 512 (lavapipe subgroup sizes 4 / 16): the output must
// be identical, since the shader's subgroup reduction is subgroup-size independent.
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_commands.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_image.h"
#include "gauss/render/vk_pipeline.h"
#include "gauss/shaders/test_pattern.comp.spv.h"
#include "golden.h"
#include "test_pattern_layout.h"
#include "vk_test.h"

namespace {

using gauss::gpu::TEST_PATTERN_WORKGROUP;

constexpr std::uint32_t kWidth = 200;   // not a multiple of the workgroup: partial tiles
constexpr std::uint32_t kHeight = 120;
constexpr std::uint32_t kSeed = 12345;
constexpr std::uint32_t kRMul = 7;

std::uint32_t tiles(std::uint32_t n) { return (n + TEST_PATTERN_WORKGROUP - 1) / TEST_PATTERN_WORKGROUP; }

// The shader's float math, one IEEE single operation at a time. No FMA contraction
// happens here: the x86-64 baseline this builds for has no FMA instruction.
std::uint32_t pattern_green(std::uint32_t x, std::uint32_t y) {
  const float fx = static_cast<float>(x) * (1.0f / 64.0f);
  const float fy = static_cast<float>(y) * 0.37f;
  const float a = fx * 0.7f;
  const float b = fy * fy;
  const float c = b * 0.01f;
  const float f = a + c;
  return static_cast<std::uint32_t>(f * 40.0f) & 255u;
}

// CPU version of shaders/test_pattern.comp (see shaders/shared/test_pattern_layout.h).
gauss::ImageRGBA8 cpu_pattern(std::uint32_t w, std::uint32_t h, std::uint32_t seed, std::uint32_t r_mul,
                              std::vector<std::uint32_t>& out_tile_sums) {
  const std::uint32_t tx = tiles(w);
  const std::uint32_t ty = tiles(h);
  std::vector<std::uint32_t> sums(tx * ty, 0);
  std::vector<std::uint32_t> counts(tx * ty, 0);
  for (std::uint32_t y = 0; y < h; ++y) {
    for (std::uint32_t x = 0; x < w; ++x) {
      const std::uint32_t t = (y / TEST_PATTERN_WORKGROUP) * tx + x / TEST_PATTERN_WORKGROUP;
      sums[t] += (x ^ y) + seed;
      counts[t] += 1;
    }
  }
  gauss::ImageRGBA8 img{w, h, std::vector<std::uint8_t>(std::size_t{w} * h * 4)};
  for (std::uint32_t y = 0; y < h; ++y) {
    for (std::uint32_t x = 0; x < w; ++x) {
      const std::uint32_t tile_x = x / TEST_PATTERN_WORKGROUP;
      const std::uint32_t tile_y = y / TEST_PATTERN_WORKGROUP;
      const std::uint32_t t = tile_y * tx + tile_x;
      std::uint8_t* p = &img.pixels[(std::size_t{y} * w + x) * 4];
      p[0] = static_cast<std::uint8_t>((x * r_mul + y * 3u + seed) & 255u);
      p[1] = static_cast<std::uint8_t>(pattern_green(x, y));
      p[2] = static_cast<std::uint8_t>((sums[t] + 3u * counts[t]) & 255u);
      p[3] = ((tile_x + tile_y) & 1u) == 0 ? 255 : 191;
    }
  }
  out_tile_sums = sums;
  return img;
}

class VkGoldenPattern : public gauss::test::VkTest {};

TEST_F(VkGoldenPattern, MatchesGoldenAndCpuReference) {
  auto& ctx = context();
  // The fixture checks GAUSS_EXPECT_SUBGROUP_SIZE (the subgroup-size variants).
  const VkSubgroupFeatureFlags needed = VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT;
  ASSERT_EQ(ctx.subgroup_operations() & needed, needed) << "device lacks compute subgroup arithmetic";

  auto target = gauss::vk::OffscreenTarget::create(ctx, kWidth, kHeight, "pattern");
  ASSERT_TRUE(target) << target.message();
  const std::uint32_t tile_count = tiles(kWidth) * tiles(kHeight);
  auto tile_sums = gauss::vk::Buffer::create(ctx, {.size = tile_count * sizeof(std::uint32_t), .name = "tile sums"});
  ASSERT_TRUE(tile_sums) << tile_sums.message();
  auto pipeline = gauss::vk::ComputePipeline::create(
      ctx, {.name = "test pattern",
            .shader = gauss::vk::spirv(gauss_spv_test_pattern_comp),
            .bindings = {{gauss::gpu::TEST_PATTERN_BINDING_IMAGE, gauss::vk::DescriptorKind::StorageImage},
                         {gauss::gpu::TEST_PATTERN_BINDING_TILE_SUMS, gauss::vk::DescriptorKind::StorageBuffer}},
            .push_constant_size = sizeof(gauss::gpu::TestPatternPush),
            .spec_constants = {{gauss::gpu::TEST_PATTERN_SPEC_R_MUL, kRMul}}});
  ASSERT_TRUE(pipeline) << pipeline.message();

  gauss::Status bound = gauss::Ok{};
  auto st = ctx.submit_and_wait([&](VkCommandBuffer cmd) {
    target->color().transition(cmd, VK_IMAGE_LAYOUT_GENERAL);
    bound = pipeline->bind(cmd, {{gauss::gpu::TEST_PATTERN_BINDING_IMAGE, &target->color()},
                                 {gauss::gpu::TEST_PATTERN_BINDING_TILE_SUMS, &*tile_sums}});
    if (!bound) return;
    pipeline->push_constants(cmd, gauss::gpu::TestPatternPush{kWidth, kHeight, kSeed, 0});
    vkCmdDispatch(cmd, tiles(kWidth), tiles(kHeight), 1);
    gauss::vk::compute_to_transfer_barrier(cmd);
  });
  ASSERT_TRUE(bound) << bound.message();
  ASSERT_TRUE(st) << st.message();

  auto image = target->read_color(ctx);
  ASSERT_TRUE(image) << image.message();
  std::vector<std::uint32_t> expected_sums;
  const gauss::ImageRGBA8 expected = cpu_pattern(kWidth, kHeight, kSeed, kRMul, expected_sums);
  EXPECT_TRUE(gauss::test::images_equal(expected, *image, "compute_pattern_vs_cpu"));
  EXPECT_GOLDEN(ctx, *image, "compute_pattern", expected);

  std::vector<std::uint32_t> sums(tile_count);
  auto dl = tile_sums->download(sums.data(), sums.size() * sizeof(std::uint32_t));
  ASSERT_TRUE(dl) << dl.message();
  EXPECT_EQ(sums, expected_sums);
}

// The CPU reference is what verifies the golden, so it must itself be right on
// hand-computed pixels.
TEST(VkGoldenPatternCpu, ReferenceHandChecked) {
  std::vector<std::uint32_t> sums;
  const auto img = cpu_pattern(20, 18, 5, 7, sums);
  // Pixel (0,0): R = 5, G = 0, tile (0,0) holds 16x16 pixels: sum of (x^y)+5.
  std::uint32_t s = 0;
  for (std::uint32_t y = 0; y < 16; ++y)
    for (std::uint32_t x = 0; x < 16; ++x) s += (x ^ y) + 5;
  EXPECT_EQ(img.pixels[0], 5);
  EXPECT_EQ(img.pixels[1], 0);
  EXPECT_EQ(img.pixels[2], (s + 3u * 256u) & 255u);
  EXPECT_EQ(img.pixels[3], 255);
  ASSERT_EQ(sums.size(), 4u);
  EXPECT_EQ(sums[0], s);
  // Pixel (19,17) lies in tile (1,1): a 4x2 partial tile, alpha 255 (1+1 even).
  const std::size_t p = (17 * 20 + 19) * 4;
  EXPECT_EQ(img.pixels[p + 0], (19u * 7u + 17u * 3u + 5u) & 255u);
  // f = 19/64*0.7 + (17*0.37)^2*0.01 = 0.2078 + 0.3956 = 0.6034 -> 24.1 -> 24
  EXPECT_EQ(img.pixels[p + 1], 24);
  EXPECT_EQ(img.pixels[p + 3], 255);
  std::uint32_t s11 = 0;
  for (std::uint32_t y = 16; y < 18; ++y)
    for (std::uint32_t x = 16; x < 20; ++x) s11 += (x ^ y) + 5;
  EXPECT_EQ(sums[3], s11);
  EXPECT_EQ(img.pixels[p + 2], (s11 + 3u * 8u) & 255u);
}

// The golden helpers themselves: a mismatch reports count, max difference and the
// first pixel and writes actual + diff images; a missing golden fails with the
// approve-goldens command; goldens are never written by a test.
TEST(GoldenSupport, MismatchIsReportedWithFiles) {
  gauss::ImageRGBA8 a{4, 3, std::vector<std::uint8_t>(4 * 3 * 4, 10)};
  gauss::ImageRGBA8 b = a;
  EXPECT_TRUE(gauss::test::images_equal(a, b, "golden_support_same"));
  b.pixels[(1 * 4 + 2) * 4 + 1] = 17;  // pixel (2, 1), green: difference 7
  b.pixels[(2 * 4 + 3) * 4 + 0] = 12;  // pixel (3, 2), red: difference 2
  const auto out = gauss::test::output_dir();
  std::filesystem::remove(out / "golden_support_diff.actual.png");
  std::filesystem::remove(out / "golden_support_diff.diff.png");
  auto result = gauss::test::images_equal(a, b, "golden_support_diff");
  ASSERT_FALSE(result);
  const std::string msg = result.message();
  EXPECT_NE(msg.find("2 of 12 pixels differ"), std::string::npos) << msg;
  EXPECT_NE(msg.find("max channel difference 7"), std::string::npos) << msg;
  EXPECT_NE(msg.find("(2, 1)"), std::string::npos) << msg;
  auto actual = gauss::read_png_rgba8(out / "golden_support_diff.actual.png");
  ASSERT_TRUE(actual) << actual.message();
  EXPECT_EQ(actual->pixels, b.pixels);
  auto diff = gauss::read_png_rgba8(out / "golden_support_diff.diff.png");
  ASSERT_TRUE(diff) << diff.message();
  EXPECT_EQ(diff->pixels[(1 * 4 + 2) * 4 + 0], 255);  // marked magenta
  EXPECT_EQ(diff->pixels[(1 * 4 + 2) * 4 + 1], 0);

  gauss::ImageRGBA8 small{2, 2, std::vector<std::uint8_t>(16, 0)};
  EXPECT_FALSE(gauss::test::images_equal(a, small, "golden_support_size"));
  EXPECT_FALSE(gauss::test::images_equal(a, b, "Bad Name"));
}

TEST(GoldenSupport, MissingGoldenFailsWithApproveCommand) {
  const std::string name = "golden_support_never_approved";
  ASSERT_FALSE(std::filesystem::exists(gauss::test::golden_dir() / (name + ".png")));
  gauss::ImageRGBA8 img{2, 2, std::vector<std::uint8_t>(16, 200)};
  auto result = gauss::test::matches_golden(img, name);
  ASSERT_FALSE(result);
  EXPECT_NE(std::string(result.message()).find("scripts/approve-goldens"), std::string::npos) << result.message();
  EXPECT_FALSE(std::filesystem::exists(gauss::test::golden_dir() / (name + ".png"))) << "a test wrote a golden";
  EXPECT_TRUE(std::filesystem::exists(gauss::test::output_dir() / (name + ".actual.png")));
}

// Off lavapipe a golden check is the reference tolerance: 1/255 off the reference in a few
// pixels passes (what the H100 showed), 3/255 fails, and so does a missing golden; the
// exact check still fails the 1/255 image.
TEST(GoldenSupport, ReferenceToleranceOffLavapipe) {
  using gauss::test::GoldenCheck;
  auto golden = gauss::read_png_rgba8(gauss::test::golden_dir() / "compute_pattern.png");
  ASSERT_TRUE(golden) << golden.message();
  const gauss::ImageRGBA8& reference = *golden;  // here the reference equals the golden
  gauss::ImageRGBA8 near = reference;
  for (std::size_t p : {std::size_t{0}, std::size_t{4 * 101 + 1}, std::size_t{4 * 5000 + 2}})
    near.pixels[p] = static_cast<std::uint8_t>(near.pixels[p] ^ 1u);  // one channel 1/255 off
  EXPECT_TRUE(gauss::test::matches_golden(GoldenCheck::ReferenceTolerance, near, "compute_pattern", reference));
  EXPECT_FALSE(gauss::test::matches_golden(GoldenCheck::Exact, near, "compute_pattern", reference));
  gauss::ImageRGBA8 far = reference;
  far.pixels[4 * 300] = static_cast<std::uint8_t>(far.pixels[4 * 300] < 128 ? far.pixels[4 * 300] + 3 : far.pixels[4 * 300] - 3);
  EXPECT_FALSE(gauss::test::matches_golden(GoldenCheck::ReferenceTolerance, far, "golden_support_far", reference));
  EXPECT_FALSE(gauss::test::matches_golden(GoldenCheck::ReferenceTolerance, far, "compute_pattern", reference));
  EXPECT_FALSE(
      gauss::test::matches_golden(GoldenCheck::ReferenceTolerance, near, "golden_support_never_approved", reference));
}

// lavapipe keeps its goldens exact: the driver is recognised (a check that silently fell back
// to the tolerance there would let 1/255 changes through unnoticed).
TEST_F(VkGoldenPattern, GoldensAreExactOnLavapipeOnly) {
  const bool lavapipe = context().device_name().find("llvmpipe") != std::string::npos;
  EXPECT_EQ(gauss::test::golden_check_for(context()),
            lavapipe ? gauss::test::GoldenCheck::Exact : gauss::test::GoldenCheck::ReferenceTolerance)
      << context().device_name();
}

}  // namespace
