// The validation messenger really catches errors: an invalid create info and a leaked
// object each raise the error count (on a fresh context, with validation requested
// explicitly), and the fixture's own zero-errors check is switched off for these tests.
#include <string>

#include <gtest/gtest.h>

#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_commands.h"
#include "gauss/render/vk_context.h"
#include "vk_test.h"

namespace {

using gauss::vk::Context;

class VkValidationTest : public gauss::test::VkTest {};

TEST_F(VkValidationTest, InvalidCreateInfoIsCounted) {
  allow_validation_errors();
  auto ctx = Context::create({.app_name = "validation-test", .enable_validation = true});
  ASSERT_TRUE(ctx) << ctx.message();
  ASSERT_TRUE((*ctx)->validation_enabled());
  EXPECT_EQ((*ctx)->validation_error_count(), 0u) << (*ctx)->last_validation_error();
  const auto process_before = gauss::vk::process_validation_error_count();

  // maxLod < minLod is invalid usage (VUID-VkSamplerCreateInfo-maxLod-01973) that the
  // driver tolerates, so provoking it is safe.
  VkSamplerCreateInfo sci{};
  sci.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
  sci.minLod = 1.0f;
  sci.maxLod = 0.0f;
  VkSampler sampler = VK_NULL_HANDLE;
  const VkResult r = vkCreateSampler((*ctx)->device(), &sci, nullptr, &sampler);
  if (r == VK_SUCCESS) vkDestroySampler((*ctx)->device(), sampler, nullptr);

  EXPECT_GE((*ctx)->validation_error_count(), 1u);
  EXPECT_GE(gauss::vk::process_validation_error_count(), process_before + 1);
  EXPECT_NE((*ctx)->last_validation_error().find("maxLod"), std::string::npos) << (*ctx)->last_validation_error();
}

TEST_F(VkValidationTest, LeakedObjectIsReportedOnDestroy) {
  allow_validation_errors();
  auto ctx = Context::create({.app_name = "leak-test", .enable_validation = true});
  ASSERT_TRUE(ctx) << ctx.message();
  VkFenceCreateInfo fci{};
  fci.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
  VkFence leaked = VK_NULL_HANDLE;
  ASSERT_EQ(vkCreateFence((*ctx)->device(), &fci, nullptr, &leaked), VK_SUCCESS);
  const auto before = gauss::vk::process_validation_error_count();
  ctx->reset();  // destroys the device with the fence still alive
  EXPECT_GT(gauss::vk::process_validation_error_count(), before) << "the leaked VkFence was not reported";
}

// Synchronization validation finds a missing barrier (two copies writing the same
// bytes back to back), and the helper barrier makes it go away.
TEST_F(VkValidationTest, SynchronizationValidationCatchesMissingBarrier) {
  allow_validation_errors();
  auto ctx = Context::create({.app_name = "sync-test", .synchronization_validation = true});
  ASSERT_TRUE(ctx) << ctx.message();
  auto a = gauss::vk::Buffer::create(**ctx, {.size = 256, .name = "a"});
  auto b = gauss::vk::Buffer::create(**ctx, {.size = 256, .name = "b"});
  ASSERT_TRUE(a && b);
  const VkBufferCopy region{0, 0, 256};
  auto record = [&](bool with_barrier) {
    return (*ctx)->submit_and_wait([&](VkCommandBuffer cmd) {
      (void)gauss::vk::record_fill(cmd, *a, 0, 256, 1u);
      if (with_barrier) {
        gauss::vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                  VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
      }
      (void)gauss::vk::record_copy(cmd, *a, *b, {&region, 1});
    });
  };
  const auto before = (*ctx)->validation_error_count();
  ASSERT_TRUE(record(true));
  EXPECT_EQ((*ctx)->validation_error_count(), before) << (*ctx)->last_validation_error();
  ASSERT_TRUE(record(false));
  EXPECT_GT((*ctx)->validation_error_count(), before) << "the read-after-write hazard was not reported";
  EXPECT_NE((*ctx)->last_validation_error().find("SYNC-HAZARD"), std::string::npos) << (*ctx)->last_validation_error();
}

TEST_F(VkValidationTest, CleanContextReportsNothing) {
  const auto before = gauss::vk::process_validation_error_count();
  {
    auto ctx = Context::create({.app_name = "clean", .enable_validation = true});
    ASSERT_TRUE(ctx) << ctx.message();
    ASSERT_TRUE((*ctx)->wait_idle());
  }
  EXPECT_EQ(gauss::vk::process_validation_error_count(), before);
}

}  // namespace
