// SplatRenderer (Vulkan compute) against the CPU reference rasterizer (double precision):
// single Gaussians, a procedural SH3 scene, exact-culling invariance, determinism, and
// "host render == client render" (two renderer instances, same bytes).
#include <algorithm>

#include <gtest/gtest.h>

#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_context.h"
#include "golden.h"
#include "splat_test_util.h"
#include "vk_test.h"

namespace gauss::test {
namespace {

class SplatReference : public VkTest {
 protected:
  std::unique_ptr<render::SplatRenderer> make(std::uint32_t capacity, int degree, std::uint32_t w = 320,
                                              std::uint32_t h = 240) {
    auto r = render::SplatRenderer::create(context(), {.capacity = capacity, .sh_degree = degree, .max_width = w,
                                                       .max_height = h});
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.message());
    return r.ok() ? std::move(*r) : nullptr;
  }

  ImageRGBA8 gpu_render(render::SplatRenderer& r, const Camera& cam, const render::SplatRenderOptions& opt = {}) {
    auto stats = r.render(cam, opt);
    EXPECT_TRUE(stats.ok()) << (stats.ok() ? "" : stats.message());
    auto img = r.read_image();
    EXPECT_TRUE(img.ok()) << (img.ok() ? "" : img.message());
    return img.ok() ? *img : ImageRGBA8{};
  }

  ImageRGBA8 ref_render(std::span<const Gaussian> g, int degree, const Camera& cam,
                        const render::ReferenceOptions& opt = {}) {
    auto ref = render::render_reference(g, {}, degree, cam, opt);
    EXPECT_TRUE(ref.ok()) << (ref.ok() ? "" : ref.message());
    return ref.ok() ? ref->rgba8 : ImageRGBA8{};
  }
};

TEST_F(SplatReference, SingleGaussiansMatchReference) {
  const Camera cam = forward_camera(160, 120);
  std::vector<Gaussian> cases;
  Gaussian g;
  g.position = {0.0f, 0.0f, 3.0f};
  g.log_scale = {-2.0f, -2.0f, -2.0f};
  g.opacity_logit = 2.0f;
  g.sh_dc = {1.0f, 0.2f, -0.5f};
  cases.push_back(g);  // centred, isotropic
  g.position = {0.4f, -0.3f, 2.0f};
  g.log_scale = {-1.5f, -3.5f, -2.5f};
  g.rotation = {0.8f, 0.3f, -0.4f, 0.33f};
  normalize_quaternion(g.rotation);
  cases.push_back(g);  // off-centre, anisotropic, rotated
  g.position = {-1.2f, 0.85f, 1.5f};  // partly off screen (frustum clamp in J)
  g.log_scale = {-1.0f, -1.0f, -1.0f};
  cases.push_back(g);
  auto r = make(1, 0, 160, 120);
  ASSERT_TRUE(r);
  for (std::size_t i = 0; i < cases.size(); ++i) {
    ASSERT_TRUE(r->write_slots(0, std::span<const Gaussian>(&cases[i], 1)).ok());
    const ImageRGBA8 gpu = gpu_render(*r, cam);
    const ImageRGBA8 ref = ref_render(std::span<const Gaussian>(&cases[i], 1), 0, cam);
    EXPECT_TRUE(close_to_reference(ref, gpu, "splat_single_" + std::to_string(i)));
  }
}

TEST_F(SplatReference, ProceduralSh3SceneMatchesReference) {
  const auto scene = procedural_scene(3000, 3);
  const Camera cam = forward_camera(320, 240);
  auto r = make(4000, 3);
  ASSERT_TRUE(r);
  ASSERT_TRUE(r->write_slots(0, scene).ok());
  const ImageRGBA8 gpu = gpu_render(*r, cam);
  const ImageRGBA8 ref = ref_render(scene, 3, cam);
  EXPECT_TRUE(close_to_reference(ref, gpu, "splat_procedural_sh3"));
  EXPECT_GOLDEN(context(), gpu, "splat_procedural_sh3", ref);
}

TEST_F(SplatReference, ExactCullingNeverChangesTheImage) {
  const auto scene = procedural_scene(3000, 2, 7);
  const Camera cam = look_at_camera(320, 240, {0.5, -0.3, -0.5}, {0.0, 0.0, 4.0});
  auto r = make(3000, 2);
  ASSERT_TRUE(r);
  ASSERT_TRUE(r->write_slots(0, scene).ok());
  render::SplatRenderOptions exact, loose;
  loose.exact_culling = false;
  auto s1 = r->render(cam, exact);
  ASSERT_TRUE(s1.ok());
  auto a = r->read_image();
  auto s2 = r->render(cam, loose);
  ASSERT_TRUE(s2.ok());
  auto b = r->read_image();
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_TRUE(images_equal(*b, *a, "splat_exact_cull"));
  std::printf("pairs with exact culling %u, without %u\n", s1->pairs, s2->pairs);
  EXPECT_LT(s1->pairs, s2->pairs);
  EXPECT_EQ(s1->visible, s2->visible);
}

// The radix sorts take one block of SORT_BLOCK (8192) keys alone (no count or histogram
// pass) and several blocks otherwise: visible counts on both sides of each boundary, with
// many exact depth ties (equal depths blend in slot order), must match the reference.
TEST_F(SplatReference, SortBlockBoundariesMatchReference) {
  const Camera cam = forward_camera(160, 120);
  Rng rng;
  for (const std::uint32_t n : {1u, 4000u, 8191u, 8192u, 8193u, 20000u}) {
    std::vector<Gaussian> scene(n);
    for (Gaussian& g : scene) {
      const float z = 2.0f + float(int(rng.next() * 64.0)) / 16.0f;  // 64 exact depths: ties
      g.position = {rng.uniform(-0.45 * z, 0.45 * z), rng.uniform(-0.32 * z, 0.32 * z), z};
      g.log_scale = glm::vec3(rng.uniform(-4.5, -3.5));
      g.opacity_logit = rng.uniform(-1.0, 3.0);
      g.sh_dc = {rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5)};
    }
    auto r = make(n, 0, 160, 120);
    ASSERT_TRUE(r);
    ASSERT_TRUE(r->write_slots(0, scene).ok());
    auto stats = r->render(cam);
    ASSERT_TRUE(stats.ok()) << stats.message();
    EXPECT_EQ(stats->visible, n);
    std::printf("n %u: %u visible, %u pairs\n", n, stats->visible, stats->pairs);
    auto gpu = r->read_image();
    ASSERT_TRUE(gpu.ok());
    EXPECT_TRUE(close_to_reference(ref_render(scene, 0, cam), *gpu, "splat_sort_blocks_" + std::to_string(n)));
  }
}

TEST_F(SplatReference, DeterministicAndHostRenderEqualsClientRender) {
  const auto scene = procedural_scene(2000, 1, 3);
  const Camera cam = forward_camera(256, 192);
  auto host = make(5000, 1, 256, 192);
  auto client = make(2000, 1, 256, 192);
  ASSERT_TRUE(host && client);
  // The host holds the same Gaussians in the same slots, written in two ranges.
  ASSERT_TRUE(host->write_slots(0, std::span(scene).first(1000)).ok());
  ASSERT_TRUE(host->write_slots(1000, std::span(scene).subspan(1000)).ok());
  ASSERT_TRUE(client->write_slots(0, scene).ok());
  const ImageRGBA8 a = gpu_render(*host, cam);
  const ImageRGBA8 b = gpu_render(*client, cam);
  const ImageRGBA8 c = gpu_render(*client, cam);
  EXPECT_TRUE(images_equal(a, b, "splat_host_vs_client"));
  EXPECT_TRUE(images_equal(b, c, "splat_render_twice"));
}

TEST_F(SplatReference, EmptySlotsAndClearsCostNothingAndDrawNothing) {
  const auto scene = procedural_scene(500, 0, 11);
  const Camera cam = forward_camera(128, 96);
  auto r = make(1000, 0, 128, 96);
  ASSERT_TRUE(r);
  ASSERT_TRUE(r->write_slots(500, scene).ok());
  EXPECT_EQ(r->high_water(), 1000u);
  ASSERT_TRUE(r->clear_slots(500, 500).ok());
  EXPECT_EQ(r->high_water(), 0u);
  auto s = r->render(cam, {.clear_colour = {0.25f, 0.5f, 1.0f}});
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s->visible, 0u);
  auto img = r->read_image();
  ASSERT_TRUE(img.ok());
  for (std::size_t p = 0; p < img->pixels.size(); p += 4) {
    ASSERT_EQ(img->pixels[p], 64);  // to_unorm8(0.25) = floor(63.75 + 0.5)
    ASSERT_EQ(img->pixels[p + 1], 128);
    ASSERT_EQ(img->pixels[p + 2], 255);
    ASSERT_EQ(img->pixels[p + 3], 255);
  }
  // Written again in place, the slots draw exactly what a fresh renderer draws.
  ASSERT_TRUE(r->write_slots(500, scene).ok());
  const ImageRGBA8 again = gpu_render(*r, cam);
  auto fresh = make(1000, 0, 128, 96);
  ASSERT_TRUE(fresh && fresh->write_slots(500, scene).ok());
  EXPECT_TRUE(images_equal(gpu_render(*fresh, cam), again, "splat_rewrite"));
}

TEST_F(SplatReference, PairOverflowKeepsTheNearestSplatsDeterministically) {
  const auto scene = procedural_scene(2000, 0, 13);
  const Camera cam = forward_camera(160, 120);
  // Without exact culling a splat's pairs are its whole tile rectangle, so the reference's
  // projection tells which splats fit: cut the pair capacity right after the 800th splat
  // in (depth key, slot) order.
  struct Item {
    float key;
    std::uint32_t slot;
    std::uint64_t tiles;
  };
  std::vector<Item> items;
  for (std::uint32_t s = 0; s < scene.size(); ++s) {
    const auto p = render::project_splat(scene[s], s, 0, cam);
    if (p.cull != render::SplatCull::Visible) continue;
    items.push_back({p.depth_key, s,
                     std::uint64_t{p.tile_max_x - p.tile_min_x} * (p.tile_max_y - p.tile_min_y)});
  }
  std::sort(items.begin(), items.end(),
            [](const Item& a, const Item& b) { return a.key != b.key ? a.key < b.key : a.slot < b.slot; });
  ASSERT_GT(items.size(), 1000u);
  std::uint64_t cap = 0;
  std::vector<std::uint8_t> kept(scene.size(), 0);
  for (std::size_t k = 0; k < 800; ++k) {
    cap += items[k].tiles;
    kept[items[k].slot] = 1;
  }
  auto r = render::SplatRenderer::create(context(), {.capacity = 2000, .sh_degree = 0, .max_width = 160,
                                                     .max_height = 120, .max_pairs = static_cast<std::uint32_t>(cap)});
  ASSERT_TRUE(r.ok()) << r.message();
  ASSERT_TRUE((*r)->write_slots(0, scene).ok());
  render::SplatRenderOptions loose;
  loose.exact_culling = false;
  auto s1 = (*r)->render(cam, loose);
  ASSERT_TRUE(s1.ok());
  const auto a = (*r)->read_image();
  auto s2 = (*r)->render(cam, loose);
  ASSERT_TRUE(s2.ok());
  const auto b = (*r)->read_image();
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_TRUE(s1->pair_overflow);
  EXPECT_EQ(s1->pairs, cap);
  EXPECT_GT(s1->pairs_needed, cap);
  EXPECT_TRUE(images_equal(*a, *b, "splat_overflow_twice"));
  auto ref = render::render_reference(scene, kept, 0, cam);
  ASSERT_TRUE(ref.ok()) << ref.message();
  EXPECT_TRUE(close_to_reference(ref->rgba8, *a, "splat_overflow_nearest_kept"));
}

// The largest renderer the device holds at SH degree 3 (splat_memory_plan.h; on lavapipe
// 4,194,304 slots, each wide per-slot array in four 128 MiB bindings): Gaussians written to
// the highest slots render exactly like the same Gaussians at slot 0 of a small renderer,
// and like the reference; one slot more is refused before anything is allocated, naming
// the limit. max_pairs is kept small: pairs do not depend on the capacity. A device whose
// limit needs more than 3 GiB (a large GPU) checks only the refusal.
TEST_F(SplatReference, LargestCapacityAtShDegree3RendersTheTopSlots) {
  const auto scene = procedural_scene(300, 3, 5);
  const Camera cam = forward_camera(128, 96);
  render::SplatRendererCreateInfo info{.capacity = 0, .sh_degree = 3, .max_width = 128, .max_height = 96,
                                       .max_pairs = 1u << 16};
  const std::uint32_t most = render::max_splat_capacity(context(), info);
  ASSERT_GT(most, 1u << 20);  // past the renderer's old fixed capacity
  info.capacity = most + 1;
  auto over = render::SplatRenderer::create(context(), info);
  ASSERT_FALSE(over.ok());
  EXPECT_NE(over.message().find("at most "), std::string::npos) << over.message();
  info.capacity = most;
  auto plan = render::plan_splat_memory(context(), info);
  ASSERT_TRUE(plan.ok()) << plan.message();
  if (plan->total_bytes > (std::uint64_t{3} << 30)) GTEST_SKIP() << "the limit needs " << plan->total_bytes << " bytes";
  auto big = render::SplatRenderer::create(context(), info);
  ASSERT_TRUE(big.ok()) << big.message();
  const std::uint32_t first = most - static_cast<std::uint32_t>(scene.size());
  ASSERT_TRUE((*big)->write_slots(first, scene).ok());
  EXPECT_EQ((*big)->high_water(), most);
  const ImageRGBA8 top = gpu_render(**big, cam);
  auto small = make(static_cast<std::uint32_t>(scene.size()), 3, 128, 96);
  ASSERT_TRUE(small && small->write_slots(0, scene).ok());
  EXPECT_TRUE(images_equal(gpu_render(*small, cam), top, "splat_top_slots"));
  EXPECT_TRUE(close_to_reference(ref_render(scene, 3, cam), top, "splat_top_slots_reference"));
}

TEST_F(SplatReference, RejectsBadInputWithClearErrors) {
  auto r = make(10, 0, 64, 64);
  ASSERT_TRUE(r);
  std::vector<Gaussian> gs(3);
  gs[1].position.x = std::numeric_limits<float>::quiet_NaN();
  ASSERT_TRUE(r->write_slots(0, gs).ok());
  EXPECT_EQ(r->rejected_nonfinite(), 1u);
  EXPECT_EQ(r->occupied_count(), 2u);
  auto past = r->write_slots(9, gs);
  ASSERT_FALSE(past.ok());
  EXPECT_NE(past.message().find("capacity"), std::string::npos) << past.message();
  Camera too_big = forward_camera(128, 64);
  auto big = r->render(too_big);
  ASSERT_FALSE(big.ok());
  EXPECT_NE(big.message().find("exceeds"), std::string::npos) << big.message();
  Camera bad = forward_camera(64, 64);
  bad.fx = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(r->render(bad).ok());
  auto zero = render::SplatRenderer::create(context(), {.capacity = 0});
  EXPECT_FALSE(zero.ok());
}

}  // namespace
}  // namespace gauss::test
