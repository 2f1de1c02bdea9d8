// The renderer's capacity is the device's (splat_memory_plan.h): per-slot arrays split into
// slot chunks when one binding cannot hold them, and a scene the device cannot hold is
// refused before anything is allocated, with the numbers. The split is exercised on small
// scenes by lowering the binding range (SplatRendererCreateInfo::max_binding_bytes): a
// split renderer must give the very bytes of an unsplit one.
#include <cmath>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/render/splat_memory_plan.h"
#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_context.h"
#include "golden.h"
#include "splat_test_util.h"
#include "vk_test.h"

namespace gauss::test {
namespace {

// 1024 SH3 slots per chunk: the widest array (SH bands 1-2) is 96 bytes per slot.
constexpr std::uint64_t kSmallBinding = 96 * 1024;

// 100 splats over the whole 160x120 view (80 tiles): 8000 pairs. The near 60 are faint, the
// far 40 red and strong, so a frame that drops the far splats' pairs looks different.
std::vector<Gaussian> layers_over_the_view() {
  std::vector<Gaussian> scene(100);
  for (std::size_t i = 0; i < scene.size(); ++i) {
    Gaussian& g = scene[i];
    g.position = glm::vec3(0.0f, 0.0f, 3.0f + 0.05f * float(i));
    g.log_scale = glm::vec3(std::log(40.0f), std::log(40.0f), std::log(0.01f));
    g.opacity_logit = i < 60 ? -4.0f : -0.8f;
    g.sh_dc = i < 60 ? glm::vec3(0.2f) : glm::vec3(1.5f, -1.0f, -1.0f);
    g.id = GaussianId{i + 1};
  }
  return scene;
}

class SplatCapacity : public VkTest {
 protected:
  render::SplatRendererCreateInfo info(std::uint32_t capacity, std::uint64_t binding_bytes) const {
    return {.capacity = capacity, .sh_degree = 3, .max_width = 96, .max_height = 64, .max_pairs = 1u << 14,
            .max_binding_bytes = binding_bytes};
  }
  ImageRGBA8 draw(render::SplatRenderer& r, const Camera& cam) {
    auto stats = r.render(cam);
    EXPECT_TRUE(stats.ok()) << (stats.ok() ? "" : stats.message());
    if (stats.ok()) {
      EXPECT_FALSE(stats->pair_overflow);
    }
    auto img = r.read_image();
    EXPECT_TRUE(img.ok()) << (img.ok() ? "" : img.message());
    return img.ok() ? *img : ImageRGBA8{};
  }
  // A 160x120 renderer holding layers_over_the_view(), with these pairs.
  std::unique_ptr<render::SplatRenderer> layered(std::uint32_t max_pairs, std::optional<bool> grow,
                                                 std::uint32_t in_flight, std::optional<bool> together = {}) {
    auto r = render::SplatRenderer::create(context(), {.capacity = 100, .sh_degree = 0, .max_width = 160,
                                                       .max_height = 120, .max_pairs = max_pairs, .grow_pairs = grow,
                                                       .frames_in_flight = in_flight, .views_together = together});
    EXPECT_TRUE(r.ok()) << r.message();
    if (!r.ok()) return nullptr;
    EXPECT_TRUE((*r)->write_slots(0, layers_over_the_view()).ok());
    return std::move(*r);
  }
};

// Writes and clears that straddle chunk boundaries, splats in every chunk: the split
// renderer (4 chunks of 1024 slots) gives the bytes of the unsplit one, and the reference.
TEST_F(SplatCapacity, SplitSlotsRenderLikeOneBinding) {
  const auto scene = procedural_scene(2500, 3, 11);
  const Camera cam = forward_camera(96, 64);
  auto split = render::SplatRenderer::create(context(), info(4096, kSmallBinding));
  ASSERT_TRUE(split.ok()) << split.message();
  auto whole = render::SplatRenderer::create(context(), info(4096, 0));
  ASSERT_TRUE(whole.ok()) << whole.message();
  EXPECT_EQ((*split)->memory_plan().slot_chunks, 4u);
  EXPECT_EQ((*split)->memory_plan().chunk_slots, 1024u);
  EXPECT_EQ((*whole)->memory_plan().slot_chunks, 1u);
  for (auto* r : {split->get(), whole->get()}) {
    ASSERT_TRUE(r->write_slots(700, std::span(scene).first(2000)).ok());  // chunks 0-2
    ASSERT_TRUE(r->write_slots(3596, std::span(scene).subspan(2000)).ok());  // chunks 3, up to the last slot
    ASSERT_TRUE(r->clear_slots(1000, 100).ok());  // across the boundary at 1024
    ASSERT_TRUE(r->set_edit_tints(2040, 20, {.kind = render::EditTintKind::Added, .age = 1}).ok());
  }
  EXPECT_EQ((*split)->high_water(), 4096u);
  const ImageRGBA8 a = draw(**split, cam);
  const ImageRGBA8 b = draw(**whole, cam);
  EXPECT_TRUE(images_equal(b, a, "splat_split_slots"));

  // Without the tints, against the reference (slot order = the order the kept ones sit in).
  for (auto* r : {split->get(), whole->get()})
    ASSERT_TRUE(r->set_edit_tints(0, 4096, {.kind = render::EditTintKind::None}).ok());
  std::vector<Gaussian> kept;
  for (std::size_t i = 0; i < scene.size(); ++i) {
    const std::size_t slot = i < 2000 ? 700 + i : 3596 + (i - 2000);
    if (slot < 1000 || slot >= 1100) kept.push_back(scene[i]);
  }
  auto ref = render::render_reference(kept, {}, 3, cam);
  ASSERT_TRUE(ref.ok()) << ref.message();
  EXPECT_TRUE(close_to_reference(ref->rgba8, draw(**split, cam), "splat_split_slots_reference"));
}

// One slot past what four bindings hold is refused by name before anything is made;
// max_splat_capacity() says where the boundary is.
TEST_F(SplatCapacity, RefusesMoreChunksThanBoundWithTheNumbers) {
  EXPECT_EQ(render::max_splat_capacity(context(), info(0, kSmallBinding)), 4096u);
  auto over = render::SplatRenderer::create(context(), info(4097, kSmallBinding));
  ASSERT_FALSE(over.ok());
  const std::string m = over.message();
  EXPECT_NE(m.find("4,097 slots"), std::string::npos) << m;
  EXPECT_NE(m.find("maxStorageBufferRange 98,304 bytes"), std::string::npos) << m;
  EXPECT_NE(m.find("at most 4,096 slots"), std::string::npos) << m;
  // Degree 0: the widest array is 64 bytes per slot, so a chunk holds 1536 -> 1024 slots.
  auto sh0 = info(4097, kSmallBinding);
  sh0.sh_degree = 0;
  EXPECT_EQ(render::max_splat_capacity(context(), sh0), 4096u);
  EXPECT_EQ(render::slot_chunk_slots(kSmallBinding, 1536, 0), 1536u);  // fits whole
  EXPECT_EQ(render::slot_chunk_slots(kSmallBinding, 1537, 0), 1024u);
}

// A scene past the device-local heap is refused with what it needs and the heap size.
TEST_F(SplatCapacity, RefusesMoreThanTheHeapWithTheNumbers) {
  auto plan = render::plan_splat_memory(context(), info(1, 0));
  ASSERT_TRUE(plan.ok()) << plan.message();
  const std::uint32_t most = render::max_splat_capacity(context(), info(0, 0));
  ASSERT_GT(most, 1u << 20);  // more than the renderer's old fixed capacity
  auto over = render::plan_splat_memory(context(), info(most + 1, 0));
  ASSERT_FALSE(over.ok());
  const std::string m = over.message();
  const bool names_limit = m.find("heap") != std::string::npos || m.find("maxStorageBufferRange") != std::string::npos ||
                           m.find("maxMemoryAllocationSize") != std::string::npos;
  EXPECT_TRUE(names_limit) << m;
  EXPECT_NE(m.find("at most "), std::string::npos) << m;
  EXPECT_TRUE(render::plan_splat_memory(context(), info(most, 0)).ok());
}

// Pairs that grow (SplatRendererCreateInfo::grow_pairs, the default with automatic pairs): a
// view needing more pairs than the renderer holds drops its farthest splats' pairs in the
// frames recorded before that was seen, and the next frame holds them all, with the image a
// renderer with room gives. Two frames in flight: the second, recorded before the first was
// read, overflows too and says so against the pairs it had. Without growth the pairs stay.
TEST_F(SplatCapacity, PairsGrowToWhatAViewNeeds) {
  const Camera cam = forward_camera(160, 120);
  auto roomy = layered(1u << 20, false, 1);
  auto fixed = layered(5000, std::nullopt, 1);  // an explicit max_pairs does not grow by default
  auto growing = layered(5000, true, 2);
  ASSERT_TRUE(roomy && fixed && growing);

  auto all = roomy->render(cam);
  ASSERT_TRUE(all.ok()) << all.message();
  ASSERT_FALSE(all->pair_overflow);
  ASSERT_EQ(all->pairs, 8000u);
  const auto want = roomy->read_image();
  ASSERT_TRUE(want.ok());

  for (int frame = 0; frame < 2; ++frame) {
    auto s = fixed->render(cam);
    ASSERT_TRUE(s.ok()) << s.message();
    EXPECT_TRUE(s->pair_overflow);
    EXPECT_EQ(s->pairs, 5000u);
    EXPECT_EQ(s->pairs_needed, 8000u);
  }
  EXPECT_EQ(fixed->max_pairs(), 5000u);
  const auto cut = fixed->read_image();
  ASSERT_TRUE(cut.ok());
  EXPECT_NE(cut->pixels, want->pixels) << "the far splats' pairs left no trace: the test shows nothing";

  std::uint64_t serial[3];
  for (auto& s : serial) {
    auto r = growing->render_frame(std::span<const Camera>(&cam, 1));
    ASSERT_TRUE(r.ok()) << r.message();
    s = *r;
  }
  std::array<render::SplatFrameStats, 3> st;
  for (std::size_t k = 0; k < 3; ++k) {
    auto r = growing->frame_stats(serial[k]);
    ASSERT_TRUE(r.ok()) << r.message();
    st[k] = (*r)[0];
  }
  EXPECT_TRUE(st[0].pair_overflow);
  EXPECT_EQ(st[0].pairs, 5000u);
  EXPECT_TRUE(st[1].pair_overflow) << "recorded before the first frame was read";
  EXPECT_FALSE(st[2].pair_overflow);
  EXPECT_EQ(st[2].pairs, 8000u);
  EXPECT_GE(growing->max_pairs(), 8000u);
  const auto grown = growing->read_image();
  ASSERT_TRUE(grown.ok());
  EXPECT_TRUE(images_equal(*want, *grown, "splat_pairs_grown"));
  // Later frames replay the passes recorded with the grown buffers: the same image.
  ASSERT_TRUE(growing->render(cam).ok());
  const auto again = growing->read_image();
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(images_equal(*want, *again, "splat_pairs_grown_replayed"));
}

// Two views recorded together grow both views' sort buffers (the second view's scratch is
// made at the first such frame, with the pairs of that time).
TEST_F(SplatCapacity, PairsGrowForTwoViewsRecordedTogether) {
  const Camera left = forward_camera(160, 120);
  Camera right = left;
  right.cx += 3.0;
  auto roomy = layered(1u << 20, false, 1, true);
  auto growing = layered(5000, true, 1, true);
  ASSERT_TRUE(roomy && growing);
  auto all = roomy->render_stereo(left, right);
  ASSERT_TRUE(all.ok()) << all.message();
  ASSERT_TRUE((*all)[0].views_together);
  auto first = growing->render_stereo(left, right);
  ASSERT_TRUE(first.ok()) << first.message();
  EXPECT_TRUE((*first)[0].pair_overflow && (*first)[1].pair_overflow);
  auto second = growing->render_stereo(left, right);
  ASSERT_TRUE(second.ok()) << second.message();
  for (std::uint32_t v = 0; v < 2; ++v) {
    EXPECT_TRUE((*second)[v].views_together);
    EXPECT_FALSE((*second)[v].pair_overflow) << "view " << v;
    EXPECT_EQ((*second)[v].pairs, (*all)[v].pairs) << "view " << v;
    const auto want = roomy->read_image(v);
    const auto got = growing->read_image(v);
    ASSERT_TRUE(want.ok() && got.ok());
    EXPECT_TRUE(images_equal(*want, *got, v == 0 ? "splat_pairs_grown_left" : "splat_pairs_grown_right"));
  }
}

// Plans against devices this machine does not have (made-up limits, no Vulkan): the pairs a
// view may hold grow with the scene where the device has room, instead of stopping at 32M.
render::SplatDeviceLimits gpu_with(std::uint64_t heap_bytes) {
  return {.name = "made-up GPU", .binding_range = 0xFFFFFFFFu, .heap_bytes = heap_bytes, .max_allocation = 1ull << 40};
}

render::SplatRendererCreateInfo sixteen_million_sh3_at_1080p(std::uint32_t max_pairs = 0) {
  return {.capacity = 16'000'000, .sh_degree = 3, .max_width = 1920, .max_height = 1080, .max_pairs = max_pairs};
}

TEST(SplatMemoryPlan, SixteenMillionShDegree3FitA16GBGpuWithSixteenPairsPerSlot) {
  const auto device = gpu_with(16'000'000'000ull);
  auto plan = render::plan_splat_memory(device, sixteen_million_sh3_at_1080p());
  ASSERT_TRUE(plan.ok()) << plan.message();
  EXPECT_EQ(plan->max_pairs, 16u * 16'000'000u);  // a 16M box at 1080p needs about 130M
  EXPECT_LE(plan->total_bytes, device.heap_bytes);
}

TEST(SplatMemoryPlan, PairsPast32MTakeAtMostHalfTheHeapTheRestLeavesFree) {
  const auto device = gpu_with(10ull << 30);
  auto floor = render::plan_splat_memory(device, sixteen_million_sh3_at_1080p(32u << 20));
  ASSERT_TRUE(floor.ok()) << floor.message();
  const std::uint64_t budget = floor->total_bytes + (device.heap_bytes - floor->total_bytes) / 2;
  auto plan = render::plan_splat_memory(device, sixteen_million_sh3_at_1080p());
  ASSERT_TRUE(plan.ok()) << plan.message();
  EXPECT_GT(plan->max_pairs, 32u << 20);
  EXPECT_LT(plan->max_pairs, 16u * 16'000'000u);
  EXPECT_LE(plan->total_bytes, budget);
  // The most that fit: one pair more would pass the budget.
  auto one_more = render::plan_splat_memory(device, sixteen_million_sh3_at_1080p(plan->max_pairs + 1));
  ASSERT_TRUE(one_more.ok()) << one_more.message();
  EXPECT_GT(one_more->total_bytes, budget);
}

TEST(SplatMemoryPlan, AutomaticPairsPast32MNeverDecideWhetherACapacityFits) {
  const auto device = gpu_with(10ull << 30);
  auto info = sixteen_million_sh3_at_1080p();
  const std::uint32_t most = render::max_splat_capacity(device, info);
  info.capacity = most;
  auto at_most = render::plan_splat_memory(device, info);
  ASSERT_TRUE(at_most.ok()) << at_most.message();
  EXPECT_EQ(at_most->max_pairs, 32u << 20);  // no room left for more
  info.max_pairs = 32u << 20;  // the same capacity with 32M pairs asked for
  EXPECT_TRUE(render::plan_splat_memory(device, info).ok());
  info.capacity = most + 1;
  info.max_pairs = 0;
  auto over = render::plan_splat_memory(device, info);
  ASSERT_FALSE(over.ok());
  EXPECT_NE(over.message().find("heap"), std::string::npos) << over.message();
}

TEST(SplatMemoryPlan, LavapipesBindingsPlanThePairsTheyAlwaysDid) {
  const render::SplatDeviceLimits lavapipe{
      .name = "lavapipe-like", .binding_range = 128u << 20, .heap_bytes = 2ull << 30, .max_allocation = 2ull << 30};
  for (std::uint32_t capacity : {1000u, 100'000u, 1'000'000u, 2'000'000u, 4'000'000u}) {
    auto plan = render::plan_splat_memory(
        lavapipe, {.capacity = capacity, .sh_degree = 3, .max_width = 320, .max_height = 240});
    ASSERT_TRUE(plan.ok()) << plan.message();
    EXPECT_EQ(plan->max_pairs, std::min<std::uint64_t>(32u << 20, std::max<std::uint64_t>(1u << 20, 16ull * capacity)))
        << capacity;
  }
}

}  // namespace
}  // namespace gauss::test
