// Two million Gaussians on lavapipe: past the renderer's old fixed 2^20 slots, at SH degree
// 2 so that the 96-byte-per-slot SH array needs two 128 MiB bindings (splat_memory_plan.h).
// A tiny image keeps it to a few seconds of CPU; the image must match the CPU reference.
#include <chrono>
#include <cstdio>

#include <gtest/gtest.h>

#include "gauss/render/reference_rasterizer.h"
#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_context.h"
#include "splat_test_util.h"
#include "vk_test.h"

namespace gauss::test {
namespace {

class SplatTwoMillion : public VkTest {};

TEST_F(SplatTwoMillion, RendersLikeTheReference) {
  constexpr std::uint32_t kCount = 2'000'000;
  const auto scene = procedural_scene(kCount, 2, 21);
  const Camera cam = forward_camera(64, 48);
  const auto t0 = std::chrono::steady_clock::now();
  auto r = render::SplatRenderer::create(context(), {.capacity = kCount, .sh_degree = 2, .max_width = 64, .max_height = 48});
  ASSERT_TRUE(r.ok()) << r.message();
  if (context().max_storage_buffer_range() < std::uint64_t{kCount} * 96) {
    EXPECT_GT((*r)->memory_plan().slot_chunks, 1u);
  }
  ASSERT_TRUE((*r)->write_slots(0, scene).ok());
  auto stats = (*r)->render(cam);
  ASSERT_TRUE(stats.ok()) << stats.message();
  EXPECT_FALSE(stats->pair_overflow);
  EXPECT_GT(stats->visible, kCount / 2);
  auto img = (*r)->read_image();
  ASSERT_TRUE(img.ok()) << img.message();
  const double gpu_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  auto ref = render::render_reference(scene, {}, 2, cam);
  ASSERT_TRUE(ref.ok()) << ref.message();
  std::printf("2M SH2 at 64x48: %u chunks, %u visible, %u pairs; create + upload + render %.2f s\n",
              (*r)->memory_plan().slot_chunks, stats->visible, stats->pairs, gpu_s);
  EXPECT_TRUE(close_to_reference(ref->rgba8, *img, "splat_two_million_reference"));
}

}  // namespace
}  // namespace gauss::test
