// The renderer's linear depth converted for an OpenXR depth layer: known stored depths in a
// depth target come out of the destination image as a perspective projection's depth for the
// layer's planes (the shader against the CPU formula), nothing drawn stays at the far plane,
// depth in front of the near plane is 0, and bad planes or sizes are refused.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/render/depth_projection.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_image.h"
#include "splat_layout.h"
#include "vk_test.h"

namespace gauss::render {
namespace {

class DepthProjectionTest : public test::VkTest {};

TEST_F(DepthProjectionTest, StoredLinearDepthBecomesTheLayersProjectedDepth) {
  constexpr std::uint32_t kW = 8, kH = 4;
  constexpr double kNear = 0.05, kFar = 100.0;
  auto src = vk::OffscreenTarget::create(context(), kW, kH, "src");
  auto dst = vk::OffscreenTarget::create(context(), kW, kH, "dst");
  ASSERT_TRUE(src && dst);
  // View depths from in front of the near plane to beyond the far plane, and nothing drawn.
  std::vector<float> stored(kW * kH, 1.0f);
  const double metres[] = {0.01, 0.05, 0.0501, 0.3, 1.0, 2.5, 7.0, 40.0, 99.0, 100.0, 250.0};
  for (std::size_t i = 0; i < std::size(metres); ++i) stored[i] = float(metres[i] / gpu::SPLAT_MESH_DEPTH_SCALE);
  auto upload = vk::Buffer::create(context(), {.size = stored.size() * 4, .name = "stored depth"});
  ASSERT_TRUE(upload);
  ASSERT_TRUE(upload->upload(stored.data(), stored.size() * 4));
  auto projection = DepthProjection::create(context(), kW, kH);
  ASSERT_TRUE(projection) << projection.message();
  Status recorded = Ok{};
  auto st = context().submit_and_wait([&](VkCommandBuffer cmd) {
    src->depth().transition(cmd, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 0, 1};
    region.imageExtent = {kW, kH, 1};
    vkCmdCopyBufferToImage(cmd, upload->handle(), src->depth().handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1,
                           &region);
    dst->depth().transition(cmd, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
    recorded = projection->record(cmd, 1, &src->depth(), {kW, kH}, dst->depth().handle(),
                                  VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, kNear, kFar);
  });
  ASSERT_TRUE(st) << st.message();
  ASSERT_TRUE(recorded) << recorded.message();
  auto out = dst->read_depth(context());
  ASSERT_TRUE(out) << out.message();
  ASSERT_EQ(out->size(), stored.size());
  for (std::size_t i = 0; i < stored.size(); ++i)
    EXPECT_NEAR((*out)[i], projected_depth(stored[i], kNear, kFar), 1e-6) << "value " << i;
  EXPECT_EQ((*out)[0], 0.0f) << "in front of the near plane";
  EXPECT_EQ((*out)[1], 0.0f) << "on the near plane";
  EXPECT_EQ((*out)[9], 1.0f) << "on the far plane";
  EXPECT_EQ((*out)[10], 1.0f) << "beyond it";
  EXPECT_EQ((*out)[20], 1.0f) << "nothing drawn";
  // The formula itself: a perspective projection's depth, increasing with distance.
  EXPECT_NEAR(projected_depth(float(1.0 / gpu::SPLAT_MESH_DEPTH_SCALE), kNear, kFar),
              kFar * (1.0 - kNear) / (1.0 * (kFar - kNear)), 1e-6);
  for (std::size_t i = 2; i + 1 < std::size(metres) - 1; ++i) EXPECT_LT((*out)[i], (*out)[i + 1]);

  // A frame without a mesh never wrote the target: the layer gets the far plane throughout.
  st = context().submit_and_wait([&](VkCommandBuffer cmd) {
    dst->depth().transition(cmd, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);  // the readback moved it
    recorded = projection->record(cmd, 0, nullptr, {kW, kH}, dst->depth().handle(),
                                  VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, kNear, kFar);
  });
  ASSERT_TRUE(st && recorded) << recorded.message();
  out = dst->read_depth(context());
  ASSERT_TRUE(out) << out.message();
  for (float d : *out) EXPECT_EQ(d, 1.0f);
}

TEST_F(DepthProjectionTest, BadPlanesViewsAndSizesAreRefused) {
  auto small = DepthProjection::create(context(), 4, 4);
  ASSERT_TRUE(small);
  auto big = vk::OffscreenTarget::create(context(), 8, 4, "big");
  auto fits = vk::OffscreenTarget::create(context(), 4, 4, "fits");
  ASSERT_TRUE(big && fits);
  std::vector<Status> results;
  auto st = context().submit_and_wait([&](VkCommandBuffer cmd) {
    const VkImage d = fits->depth().handle();
    const VkImageLayout g = VK_IMAGE_LAYOUT_GENERAL;
    results.push_back(small->record(cmd, 0, &big->depth(), {8, 4}, d, g, 0.1, 10));   // over the size
    results.push_back(small->record(cmd, 0, &fits->depth(), {4, 2}, d, g, 0.1, 10));  // extents differ
    results.push_back(small->record(cmd, 2, &fits->depth(), {4, 4}, d, g, 0.1, 10));  // no view 2
    results.push_back(small->record(cmd, 0, &fits->depth(), {4, 4}, d, g, 0.0, 10));
    results.push_back(small->record(cmd, 0, &fits->depth(), {4, 4}, d, g, 5.0, 1.0));
    results.push_back(small->record(cmd, 0, &fits->depth(), {4, 4}, d, g, 0.1, std::nan("")));
  });
  ASSERT_TRUE(st) << st.message();
  for (const Status& r : results) EXPECT_FALSE(r);
  EXPECT_FALSE(DepthProjection::create(context(), 0, 4));
}

}  // namespace
}  // namespace gauss::render
