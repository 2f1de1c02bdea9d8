// The two pass shapes (SplatPassShapes: Cpu, measured on lavapipe; Gpu, for real GPUs)
// render the same bytes: both compute the same offsets and the same stable orders, so the
// images and the frame counters must be identical, at sizes on both sides of every block
// boundary of both shapes (GPU scan / radix block 4096, CPU radix block 8192, the spine's
// 256 values per step), with many exact depth ties (equal depths blend in slot order), and
// both stay within the reference tolerance. The GPU shapes render with every digit width
// the device allows (4 bits everywhere, 8 bits with subgroups of 16 or more). CTest also
// runs this at lavapipe subgroup sizes 4 and 16 (tests/CMakeLists.txt): the GPU shapes
// rank by subgroup ballot, and 16 is where lavapipe takes 8-bit digits.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>

#include <gtest/gtest.h>

#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_context.h"
#include "golden.h"
#include "splat_test_util.h"
#include "vk_test.h"

namespace gauss::test {
namespace {

using render::SplatPassShapes;

// The GPU shapes' scan and radix block (shaders/shared/splat_layout.h SORT_BLOCK_GPU).
constexpr std::uint32_t kGpuBlock = 4096;

struct Rendered {
  ImageRGBA8 image;
  render::SplatFrameStats stats;
};

// Sets an environment variable for its lifetime (nullptr: unset), restoring what was there.
class EnvOverride {
 public:
  EnvOverride(const char* name, const char* value) : name_(name) {
    if (const char* before = std::getenv(name)) saved_ = before;
    if (value) ::setenv(name, value, 1);
    else ::unsetenv(name);
  }
  ~EnvOverride() {
    if (saved_) ::setenv(name_, saved_->c_str(), 1);
    else ::unsetenv(name_);
  }
  EnvOverride(const EnvOverride&) = delete;
  EnvOverride& operator=(const EnvOverride&) = delete;

 private:
  const char* name_;
  std::optional<std::string> saved_;
};

class SplatPassShapesTest : public VkTest {
 protected:
  // Renders `scene` at slot `first_slot` onwards with the given shapes.
  Rendered render_with(SplatPassShapes shapes, std::span<const Gaussian> scene, const Camera& cam,
                       std::uint32_t capacity, std::uint32_t first_slot = 0,
                       const render::SplatRenderOptions& options = {}) {
    auto r = render::SplatRenderer::create(context(), {.capacity = capacity, .sh_degree = 0, .max_width = cam.width,
                                                       .max_height = cam.height, .pass_shapes = shapes});
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.message());
    if (!r.ok()) return {};
    EXPECT_EQ((*r)->pass_profile().shapes, shapes) << (*r)->pass_profile().reason;
    if (!scene.empty()) {
      EXPECT_TRUE((*r)->write_slots(first_slot, scene).ok());
    }
    auto stats = (*r)->render(cam, options);
    EXPECT_TRUE(stats.ok()) << (stats.ok() ? "" : stats.message());
    auto img = (*r)->read_image();
    EXPECT_TRUE(img.ok()) << (img.ok() ? "" : img.message());
    if (!stats.ok() || !img.ok()) return {};
    return {*img, *stats};
  }

  // Both shapes, the GPU ones at each digit width the device allows, compared byte for
  // byte and counter for counter; returns the last GPU shapes' render.
  Rendered both_equal(std::span<const Gaussian> scene, const Camera& cam, std::uint32_t capacity,
                      const std::string& name, std::uint32_t first_slot = 0,
                      const render::SplatRenderOptions& options = {}) {
    const Rendered cpu = render_with(SplatPassShapes::Cpu, scene, cam, capacity, first_slot, options);
    Rendered gpu;
    for (const char* bits : {"4", "8"}) {
      EnvOverride digits("GAUSS_SORT_RADIX_BITS", bits);
      auto profile = render::choose_pass_shapes(context(), SplatPassShapes::Gpu);
      if (!profile.ok()) continue;  // 8-bit rows do not fit this device's subgroups
      const std::string what = name + " (" + bits + "-bit digits)";
      gpu = render_with(SplatPassShapes::Gpu, scene, cam, capacity, first_slot, options);
      EXPECT_EQ(cpu.stats.visible, gpu.stats.visible) << what;
      EXPECT_EQ(cpu.stats.pairs, gpu.stats.pairs) << what;
      EXPECT_EQ(cpu.stats.pairs_needed, gpu.stats.pairs_needed) << what;
      EXPECT_TRUE(images_equal(cpu.image, gpu.image, "pass_shapes_" + name)) << what;
      std::printf("%s: %u visible, %u pairs\n", what.c_str(), gpu.stats.visible, gpu.stats.pairs);
    }
    return gpu;
  }
};

// n Gaussians filling forward_camera's view, on 64 exact depths (many ties).
std::vector<Gaussian> tied_box(std::uint32_t n, std::uint64_t seed) {
  Rng rng;
  rng.s ^= seed * 0x9E3779B97F4A7C15ull;
  std::vector<Gaussian> scene(n);
  for (Gaussian& g : scene) {
    const float z = 2.0f + float(int(rng.next() * 64.0)) / 16.0f;
    g.position = {rng.uniform(-0.45 * z, 0.45 * z), rng.uniform(-0.32 * z, 0.32 * z), z};
    g.log_scale = glm::vec3(rng.uniform(-4.5, -3.0));
    g.opacity_logit = rng.uniform(-1.0, 3.0);
    g.sh_dc = {rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5)};
  }
  return scene;
}

TEST_F(SplatPassShapesTest, ProfileFollowsTheDeviceAndTheOverride) {
  auto chosen = render::choose_pass_shapes(context(), SplatPassShapes::Auto);
  ASSERT_TRUE(chosen.ok()) << chosen.message();
  std::printf("auto: %s\n", chosen->reason.c_str());
  const char* env = std::getenv("GAUSS_PASS_SHAPES");
  if (env && std::string(env) == "gpu") {
    EXPECT_EQ(chosen->shapes, SplatPassShapes::Gpu);
  } else if (env && std::string(env) == "cpu") {
    EXPECT_EQ(chosen->shapes, SplatPassShapes::Cpu);
  } else if (context().properties().deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU) {
    EXPECT_EQ(chosen->shapes, SplatPassShapes::Cpu);  // lavapipe keeps the shapes measured on it
  } else {
    EXPECT_EQ(chosen->shapes, SplatPassShapes::Gpu);
  }
  for (SplatPassShapes s : {SplatPassShapes::Cpu, SplatPassShapes::Gpu}) {
    auto asked = render::choose_pass_shapes(context(), s);
    ASSERT_TRUE(asked.ok()) << asked.message();
    EXPECT_EQ(asked->shapes, s);
    EXPECT_NE(asked->reason.find(render::pass_shapes_name(s)), std::string::npos) << asked->reason;
  }
}

// The GPU shapes take 8-bit digits exactly where the device's smallest subgroup is 16 or
// more (the scatter's shared rows fit); the override picks either width where it fits and
// is refused, with the numbers, where it does not or is not a width.
TEST_F(SplatPassShapesTest, DigitWidthFollowsTheSubgroupSize) {
  EnvOverride none("GAUSS_SORT_RADIX_BITS", nullptr);
  auto gpu = render::choose_pass_shapes(context(), SplatPassShapes::Gpu);
  ASSERT_TRUE(gpu.ok()) << gpu.message();
  const bool wide = context().min_subgroup_size() >= 16;
  EXPECT_EQ(gpu->radix_bits, wide ? 8u : 4u) << gpu->reason;
  EXPECT_EQ(gpu->sort_rows, 256u / context().min_subgroup_size());
  EXPECT_NE(gpu->reason.find(wide ? "8-bit digits" : "4-bit digits"), std::string::npos) << gpu->reason;
  auto cpu = render::choose_pass_shapes(context(), SplatPassShapes::Cpu);
  ASSERT_TRUE(cpu.ok()) << cpu.message();
  EXPECT_EQ(cpu->radix_bits, 4u);
  {
    EnvOverride four("GAUSS_SORT_RADIX_BITS", "4");
    auto asked = render::choose_pass_shapes(context(), SplatPassShapes::Gpu);
    ASSERT_TRUE(asked.ok()) << asked.message();
    EXPECT_EQ(asked->radix_bits, 4u);
  }
  {
    EnvOverride eight("GAUSS_SORT_RADIX_BITS", "8");
    auto asked = render::choose_pass_shapes(context(), SplatPassShapes::Gpu);
    ASSERT_EQ(asked.ok(), wide) << (asked.ok() ? asked->reason : asked.message());
    if (asked.ok()) EXPECT_EQ(asked->radix_bits, 8u);
    else EXPECT_NE(asked.message().find("bytes of shared memory"), std::string::npos) << asked.message();
  }
  EnvOverride six("GAUSS_SORT_RADIX_BITS", "6");
  auto bad = render::choose_pass_shapes(context(), SplatPassShapes::Gpu);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("GAUSS_SORT_RADIX_BITS=6"), std::string::npos) << bad.message();
}

// Two views are recorded together with the GPU shapes and one after the other with the CPU
// shapes; GAUSS_SPLAT_STEREO overrides either way and a misspelt value is refused by name.
TEST_F(SplatPassShapesTest, StereoRecordingFollowsTheShapesAndItsOverride) {
  EnvOverride none("GAUSS_SPLAT_STEREO", nullptr);
  auto gpu = render::choose_pass_shapes(context(), SplatPassShapes::Gpu);
  auto cpu = render::choose_pass_shapes(context(), SplatPassShapes::Cpu);
  ASSERT_TRUE(gpu.ok() && cpu.ok()) << (gpu.ok() ? cpu.message() : gpu.message());
  EXPECT_TRUE(gpu->views_together) << gpu->views_reason;
  EXPECT_FALSE(cpu->views_together) << cpu->views_reason;
  EXPECT_NE(gpu->views_reason.find("together (GPU shapes)"), std::string::npos) << gpu->views_reason;
  {
    EnvOverride apart("GAUSS_SPLAT_STEREO", "apart");
    auto asked = render::choose_pass_shapes(context(), SplatPassShapes::Gpu);
    ASSERT_TRUE(asked.ok()) << asked.message();
    EXPECT_FALSE(asked->views_together);
    EXPECT_NE(asked->views_reason.find("GAUSS_SPLAT_STEREO"), std::string::npos) << asked->views_reason;
  }
  {
    EnvOverride together("GAUSS_SPLAT_STEREO", "together");
    auto asked = render::choose_pass_shapes(context(), SplatPassShapes::Cpu);
    ASSERT_TRUE(asked.ok()) << asked.message();
    EXPECT_TRUE(asked->views_together);
  }
  EnvOverride bad_value("GAUSS_SPLAT_STEREO", "both");
  auto bad = render::choose_pass_shapes(context(), SplatPassShapes::Gpu);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("GAUSS_SPLAT_STEREO=both"), std::string::npos) << bad.message();
}

// A misspelt override is refused by name, not silently ignored.
TEST_F(SplatPassShapesTest, RejectsAnUnknownOverride) {
  const char* before = std::getenv("GAUSS_PASS_SHAPES");
  const std::string saved = before ? before : "";
  ::setenv("GAUSS_PASS_SHAPES", "gpus", 1);
  auto chosen = render::choose_pass_shapes(context(), SplatPassShapes::Auto);
  auto asked = render::choose_pass_shapes(context(), SplatPassShapes::Cpu);  // an explicit choice wins
  if (before) ::setenv("GAUSS_PASS_SHAPES", saved.c_str(), 1);
  else ::unsetenv("GAUSS_PASS_SHAPES");
  ASSERT_FALSE(chosen.ok());
  EXPECT_NE(chosen.message().find("GAUSS_PASS_SHAPES=gpus"), std::string::npos) << chosen.message();
  ASSERT_TRUE(asked.ok()) << asked.message();
  EXPECT_EQ(asked->shapes, SplatPassShapes::Cpu);
}

// Scan and radix block boundaries: 4096 (GPU scan and radix block), 8192 (CPU radix
// block), and sizes that are multiples of neither.
TEST_F(SplatPassShapesTest, SameBytesAcrossBlockBoundaries) {
  const Camera cam = forward_camera(160, 120);
  for (const std::uint32_t n : {1u, 2u, 255u, 257u, 4095u, 4096u, 4097u, 8193u, 10007u}) {
    const auto scene = tied_box(n, n);
    const Rendered gpu = both_equal(scene, cam, n, "n" + std::to_string(n));
    EXPECT_EQ(gpu.stats.visible, n);
    if (n == 1u || n == 10007u) {
      auto ref = render::render_reference(scene, {}, 0, cam);
      ASSERT_TRUE(ref.ok()) << ref.message();
      EXPECT_TRUE(close_to_reference(ref->rgba8, gpu.image, "pass_shapes_reference_n" + std::to_string(n)));
    }
  }
}

// Nothing visible: an empty renderer (high-water mark 0) and slots that all cull (behind
// the camera); and a lone visible splat among culled ones.
TEST_F(SplatPassShapesTest, SameBytesWithNoneOrOneVisible) {
  const Camera cam = forward_camera(128, 96);
  EXPECT_EQ(both_equal({}, cam, 100, "empty").stats.visible, 0u);
  auto behind = tied_box(3000, 5);
  for (Gaussian& g : behind) g.position.z = -g.position.z;
  EXPECT_EQ(both_equal(behind, cam, 3000, "all_culled").stats.visible, 0u);
  behind[1777] = tied_box(1, 9)[0];
  EXPECT_EQ(both_equal(behind, cam, 3000, "one_of_3000").stats.visible, 1u);
}

// Many blocks: 40k splats at 320x240 give ~10 radix blocks of depth keys and more than 16
// blocks of (tile, splat) pairs (a histogram the spine scans in several steps of 256); the
// same splats spread over 1.2M slots (the rest empty) give more than 256 visible-scan block
// sums, so the spine's carry between its steps is exercised too. Exact culling off gives
// more pairs; a pair capacity below what the view needs cuts the farthest splats' pairs.
TEST_F(SplatPassShapesTest, SameBytesOverManyBlocks) {
  const Camera cam = forward_camera(320, 240);
  const auto scene = tied_box(40000, 3);
  const Rendered many = both_equal(scene, cam, 40000, "n40000");
  EXPECT_GT(many.stats.pairs, 16u * kGpuBlock);
  render::SplatRenderOptions loose;
  loose.exact_culling = false;
  both_equal(scene, cam, 40000, "n40000_loose", 0, loose);
  constexpr std::uint32_t kSpread = 1'200'000;
  EXPECT_GT(kSpread / kGpuBlock, 256u);
  both_equal(scene, cam, kSpread, "n40000_at_top", kSpread - 40000);

  // Pair overflow: both shapes drop the same farthest pairs.
  const std::uint32_t cap = many.stats.pairs / 2;
  ImageRGBA8 images[2];
  std::uint32_t pairs[2] = {};
  int k = 0;
  for (SplatPassShapes s : {SplatPassShapes::Cpu, SplatPassShapes::Gpu}) {
    auto r = render::SplatRenderer::create(context(), {.capacity = 40000, .sh_degree = 0, .max_width = 320,
                                                       .max_height = 240, .max_pairs = cap, .pass_shapes = s});
    ASSERT_TRUE(r.ok()) << r.message();
    ASSERT_TRUE((*r)->write_slots(0, scene).ok());
    auto stats = (*r)->render(cam);
    ASSERT_TRUE(stats.ok()) << stats.message();
    EXPECT_TRUE(stats->pair_overflow);
    pairs[k] = stats->pairs;
    auto img = (*r)->read_image();
    ASSERT_TRUE(img.ok());
    images[k++] = *img;
  }
  EXPECT_EQ(pairs[0], cap);
  EXPECT_EQ(pairs[1], cap);
  EXPECT_TRUE(images_equal(images[0], images[1], "pass_shapes_pair_overflow"));
}

// More than 256 radix blocks of pairs: 70k splats each covering all 16 tiles of a 64x64
// view make over 2^20 (tile, splat) pairs, so the per-digit offset rows of the tile sort
// (sort_radix_offsets_gpu.comp, 256 blocks per step) carry a running sum between steps.
TEST_F(SplatPassShapesTest, SameBytesOverMoreThan256PairBlocks) {
  const Camera cam = forward_camera(64, 64);
  auto scene = tied_box(70000, 11);
  for (Gaussian& g : scene) {
    g.log_scale = glm::vec3(std::log(2.0f));
    g.opacity_logit = 4.0f;  // opaque: the blend stops after a few splats per pixel
  }
  const Rendered big = both_equal(scene, cam, 70000, "n70000_wide");
  EXPECT_GT(big.stats.pairs, 256u * kGpuBlock);
  EXPECT_FALSE(big.stats.pair_overflow);
}

// Splats whose alpha >= 1/255 region ends inside tiles at every angle: faint, thin and
// rotated ones (opacity from just under 1/255 to 0.9, aspect up to 1000:1), and huge ones
// whose centres lie far off the image, with exact culling off too so that tiles also get
// splats that reach none of their pixels. The GPU shapes render the CPU shapes' bytes.
TEST_F(SplatPassShapesTest, SameBytesWithFaintThinAndFarSplats) {
  const Camera cam = forward_camera(160, 120);
  Rng rng;
  rng.s ^= 0xB1E5D0ull;
  std::vector<Gaussian> scene(6000);
  for (std::size_t i = 0; i < scene.size(); ++i) {
    Gaussian& g = scene[i];
    const float z = float(rng.uniform(1.5, 6.0));
    g.position = {rng.uniform(-0.5 * z, 0.5 * z), rng.uniform(-0.37 * z, 0.37 * z), z};
    const double thin = rng.uniform(-7.0, -3.5), wide = rng.uniform(-3.5, -1.5);
    g.log_scale = glm::vec3(float(wide), float(i % 3 == 0 ? wide : thin), float(thin));
    g.rotation = glm::normalize(glm::vec4(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)));
    // opacity from 1/300 (below the 1/255 cut everywhere) to 0.9
    g.opacity_logit = float(rng.uniform(-5.7, 2.2));
    g.sh_dc = {rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5)};
    if (i % 97 == 0) {  // huge, centre far off the image, its faint edge crossing it
      g.position.x = (i % 2 ? 3.0f : -3.0f) * z;
      g.log_scale = glm::vec3(float(std::log(1.2 * z)), float(std::log(0.05 * z)), float(std::log(0.3 * z)));
      g.opacity_logit = -3.0f;
    }
  }
  render::SplatRenderOptions loose;
  loose.exact_culling = false;
  both_equal(scene, cam, std::uint32_t(scene.size()), "faint_thin_far_loose", 0, loose);
  const Rendered exact = both_equal(scene, cam, std::uint32_t(scene.size()), "faint_thin_far");
  auto ref = render::render_reference(scene, {}, 0, cam);
  ASSERT_TRUE(ref.ok()) << ref.message();
  EXPECT_TRUE(close_to_reference(ref->rgba8, exact.image, "pass_shapes_faint_thin_far_reference"));
}

}  // namespace
}  // namespace gauss::test
