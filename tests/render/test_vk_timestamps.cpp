// GPU timestamps: non-zero, increasing around real work, converted to nanoseconds;
// a slot never written is an error rather than a hang.
#include <cstdint>

#include <gtest/gtest.h>

#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_commands.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_image.h"
#include "gauss/render/vk_pipeline.h"
#include "gauss/render/vk_timestamps.h"
#include "gauss/shaders/test_pattern.comp.spv.h"
#include "test_pattern_layout.h"
#include "vk_test.h"

namespace {

class VkTimestampTest : public gauss::test::VkTest {};

TEST_F(VkTimestampTest, IncreaseAroundADispatch) {
  auto& ctx = context();
  auto queries = gauss::vk::TimestampQueries::create(ctx, 3);
  ASSERT_TRUE(queries) << queries.message();
  auto target = gauss::vk::OffscreenTarget::create(ctx, 512, 512);
  ASSERT_TRUE(target) << target.message();
  auto sums = gauss::vk::Buffer::create(ctx, {.size = 32 * 32 * 4, .name = "sums"});
  ASSERT_TRUE(sums) << sums.message();
  auto pipeline = gauss::vk::ComputePipeline::create(
      ctx, {.name = "pattern",
            .shader = gauss::vk::spirv(gauss_spv_test_pattern_comp),
            .bindings = {{gauss::gpu::TEST_PATTERN_BINDING_IMAGE, gauss::vk::DescriptorKind::StorageImage},
                         {gauss::gpu::TEST_PATTERN_BINDING_TILE_SUMS, gauss::vk::DescriptorKind::StorageBuffer}},
            .push_constant_size = sizeof(gauss::gpu::TestPatternPush)});
  ASSERT_TRUE(pipeline) << pipeline.message();

  gauss::Status bound = gauss::Ok{};
  auto st = ctx.submit_and_wait([&](VkCommandBuffer cmd) {
    queries->reset(cmd);
    queries->write(cmd, 0);
    target->color().transition(cmd, VK_IMAGE_LAYOUT_GENERAL);
    bound = pipeline->bind(cmd, {{0, &target->color()}, {1, &*sums}});
    pipeline->push_constants(cmd, gauss::gpu::TestPatternPush{512, 512, 1, 0});
    vkCmdDispatch(cmd, 32, 32, 1);
    queries->write(cmd, 1);
    queries->write(cmd, 2);
  });
  ASSERT_TRUE(st) << st.message();
  ASSERT_TRUE(bound) << bound.message();
  auto ticks = queries->read_ticks();
  ASSERT_TRUE(ticks) << ticks.message();
  ASSERT_EQ(ticks->size(), 3u);
  EXPECT_GT((*ticks)[0], 0u);
  EXPECT_GT((*ticks)[1], (*ticks)[0]) << "a 512x512 dispatch must take measurable time";
  EXPECT_GE((*ticks)[2], (*ticks)[1]);
  auto ns = queries->elapsed_ns(0, 1);
  ASSERT_TRUE(ns) << ns.message();
  EXPECT_GT(*ns, 0.0);
  EXPECT_DOUBLE_EQ(*ns, static_cast<double>((*ticks)[1] - (*ticks)[0]) * ctx.timestamp_period_ns());
  EXPECT_FALSE(queries->elapsed_ns(1, 0)) << "an end before the begin is an error";
  EXPECT_FALSE(queries->elapsed_ns(0, 3)) << "slot 3 does not exist";
}

TEST_F(VkTimestampTest, UnwrittenSlotIsAnError) {
  auto& ctx = context();
  auto queries = gauss::vk::TimestampQueries::create(ctx, 2);
  ASSERT_TRUE(queries) << queries.message();
  auto st = ctx.submit_and_wait([&](VkCommandBuffer cmd) {
    queries->reset(cmd);
    queries->write(cmd, 0);
  });
  ASSERT_TRUE(st) << st.message();
  auto ticks = queries->read_ticks();
  ASSERT_FALSE(ticks);
  EXPECT_NE(ticks.message().find("timestamp 1"), std::string::npos) << ticks.message();
  EXPECT_FALSE(gauss::vk::TimestampQueries::create(ctx, 0));
}

}  // namespace
