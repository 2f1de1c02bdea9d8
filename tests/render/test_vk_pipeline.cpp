// Pipeline creation and bind checks: bad SPIR-V, push-constant limits, duplicate
// bindings, and every bind-time error (missing/undeclared/duplicate binding, wrong
// resource kind, image in the wrong layout, misaligned offset). Nothing is recorded
// when bind fails, so the command buffer stays valid (validation stays quiet).
#include <cstdint>
#include <string>

#include <gtest/gtest.h>

#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_image.h"
#include "gauss/render/vk_pipeline.h"
#include "gauss/shaders/test_pattern.comp.spv.h"
#include "test_pattern_layout.h"
#include "vk_test.h"

namespace {

using gauss::vk::ComputePipeline;
using gauss::vk::DescriptorKind;

class VkPipelineTest : public gauss::test::VkTest {
 protected:
  gauss::vk::ComputePipelineCreateInfo pattern_info() const {
    return {.name = "pattern",
            .shader = gauss::vk::spirv(gauss_spv_test_pattern_comp),
            .bindings = {{gauss::gpu::TEST_PATTERN_BINDING_IMAGE, DescriptorKind::StorageImage},
                         {gauss::gpu::TEST_PATTERN_BINDING_TILE_SUMS, DescriptorKind::StorageBuffer}},
            .push_constant_size = sizeof(gauss::gpu::TestPatternPush)};
  }
};

TEST_F(VkPipelineTest, CreationErrors) {
  auto info = pattern_info();
  const std::uint32_t garbage[8] = {1, 2, 3, 4, 5, 6, 7, 8};
  info.shader = gauss::vk::spirv(garbage);
  auto bad = ComputePipeline::create(context(), info);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.message().find("magic"), std::string::npos) << bad.message();

  info = pattern_info();
  info.shader.size_bytes = 0;
  EXPECT_FALSE(ComputePipeline::create(context(), info));

  info = pattern_info();
  info.push_constant_size = context().limits().maxPushConstantsSize + 4;
  auto big_push = ComputePipeline::create(context(), info);
  ASSERT_FALSE(big_push);
  EXPECT_NE(big_push.message().find("push constant"), std::string::npos) << big_push.message();

  info = pattern_info();
  info.bindings.push_back({gauss::gpu::TEST_PATTERN_BINDING_IMAGE, DescriptorKind::StorageBuffer});
  auto dup = ComputePipeline::create(context(), info);
  ASSERT_FALSE(dup);
  EXPECT_NE(dup.message().find("declared twice"), std::string::npos) << dup.message();

  info = pattern_info();
  info.spec_constants = {{0, 1}, {0, 2}};
  EXPECT_FALSE(ComputePipeline::create(context(), info));
}

TEST_F(VkPipelineTest, BindErrorsNameTheProblem) {
  auto pipeline = ComputePipeline::create(context(), pattern_info());
  ASSERT_TRUE(pipeline) << pipeline.message();
  auto target = gauss::vk::OffscreenTarget::create(context(), 16, 16);
  ASSERT_TRUE(target) << target.message();
  auto buf = gauss::vk::Buffer::create(context(), {.size = 4096, .name = "sums"});
  ASSERT_TRUE(buf) << buf.message();

  std::string missing, undeclared, duplicate, wrong_kind, wrong_layout, misaligned, past_end;
  gauss::Status good = gauss::Ok{};
  auto msg = [](const gauss::Status& s) { return s ? std::string("(accepted)") : s.message(); };
  auto st = context().submit_and_wait([&](VkCommandBuffer cmd) {
    // The colour image starts in UNDEFINED layout: storage needs GENERAL.
    wrong_layout = msg(pipeline->bind(cmd, {{0, &target->color()}, {1, &*buf}}));
    target->color().transition(cmd, VK_IMAGE_LAYOUT_GENERAL);
    missing = msg(pipeline->bind(cmd, {{0, &target->color()}}));
    undeclared = msg(pipeline->bind(cmd, {{0, &target->color()}, {1, &*buf}, {5, &*buf}}));
    duplicate = msg(pipeline->bind(cmd, {{0, &target->color()}, {1, &*buf}, {1, &*buf}}));
    wrong_kind = msg(pipeline->bind(cmd, {{0, &*buf}, {1, &*buf}}));
    misaligned = msg(pipeline->bind(cmd, {{0, &target->color()}, {1, &*buf, 3, 16}}));
    past_end = msg(pipeline->bind(cmd, {{0, &target->color()}, {1, &*buf, 0, 8192}}));
    good = pipeline->bind(cmd, {{0, &target->color()}, {1, &*buf, 256, 1024}});
  });
  ASSERT_TRUE(st) << st.message();
  EXPECT_TRUE(good) << good.message();
  EXPECT_NE(wrong_layout.find("GENERAL"), std::string::npos) << wrong_layout;
  EXPECT_NE(missing.find("binding 1"), std::string::npos) << missing;
  EXPECT_NE(undeclared.find("binding 5 is not declared"), std::string::npos) << undeclared;
  EXPECT_NE(duplicate.find("given 2 times"), std::string::npos) << duplicate;
  EXPECT_NE(wrong_kind.find("needs a (created) image"), std::string::npos) << wrong_kind;
  EXPECT_NE(misaligned.find("not a multiple"), std::string::npos) << misaligned;
  EXPECT_NE(past_end.find("outside"), std::string::npos) << past_end;
}

}  // namespace
