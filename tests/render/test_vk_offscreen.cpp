// Offscreen target: clear colour/depth readback (render-pass clear and transfer clear),
// PNG output, and a GraphicsPipeline drawing two overlapping triangles with depth
// testing into it (the path the mesh pass uses).
#include <array>
#include <cstdint>
#include <filesystem>

#include <gtest/gtest.h>

#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_commands.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_image.h"
#include "gauss/render/vk_pipeline.h"
#include "gauss/shaders/test_triangle.frag.spv.h"
#include "gauss/shaders/test_triangle.vert.spv.h"
#include "test_data.h"
#include "vk_test.h"

namespace {

class VkOffscreenTest : public gauss::test::VkTest {};

void expect_uniform(const gauss::ImageRGBA8& img, std::array<std::uint8_t, 4> rgba) {
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < img.pixels.size(); i += 4) {
    for (int c = 0; c < 4; ++c) wrong += img.pixels[i + c] != rgba[c] ? 1 : 0;
  }
  EXPECT_EQ(wrong, 0u) << "first pixel " << int{img.pixels[0]} << "," << int{img.pixels[1]} << ","
                       << int{img.pixels[2]} << "," << int{img.pixels[3]};
}

TEST_F(VkOffscreenTest, ClearColourAndDepthReadBack) {
  auto& ctx = context();
  auto target = gauss::vk::OffscreenTarget::create(ctx, 37, 23, "clear");
  ASSERT_TRUE(target) << target.message();
  gauss::vk::ClearValues clear;
  clear.color[0] = 0.2f;  // exact unorm8 values: 51, 102, 153, 255
  clear.color[1] = 0.4f;
  clear.color[2] = 0.6f;
  clear.color[3] = 1.0f;
  clear.depth = 0.5f;
  auto st = ctx.submit_and_wait([&](VkCommandBuffer cmd) {
    target->begin_rendering(cmd, true, clear);
    target->end_rendering(cmd);
  });
  ASSERT_TRUE(st) << st.message();
  auto img = target->read_color(ctx);
  ASSERT_TRUE(img) << img.message();
  EXPECT_EQ(img->width, 37u);
  EXPECT_EQ(img->height, 23u);
  expect_uniform(*img, {51, 102, 153, 255});
  auto depth = target->read_depth(ctx);
  ASSERT_TRUE(depth) << depth.message();
  ASSERT_EQ(depth->size(), 37u * 23u);
  for (float d : *depth) ASSERT_EQ(d, 0.5f);

  // Transfer clear after a readback (image in TRANSFER_SRC layout): layouts tracked.
  gauss::vk::ClearValues black;
  black.depth = 1.0f;
  st = ctx.submit_and_wait([&](VkCommandBuffer cmd) { target->record_clear(cmd, black); });
  ASSERT_TRUE(st) << st.message();
  img = target->read_color(ctx);
  ASSERT_TRUE(img) << img.message();
  expect_uniform(*img, {0, 0, 0, 255});
  depth = target->read_depth(ctx);
  ASSERT_TRUE(depth) << depth.message();
  for (float d : *depth) ASSERT_EQ(d, 1.0f);

  const auto png = gauss::test::output_dir() / "offscreen_clear.png";
  ASSERT_TRUE(target->write_color_png(ctx, png));
  auto reread = gauss::read_png_rgba8(png);
  ASSERT_TRUE(reread) << reread.message();
  EXPECT_EQ(reread->pixels, img->pixels);
}

struct Vertex {
  float position[4];
  float color[4];
};

TEST_F(VkOffscreenTest, GraphicsPipelineDrawsWithDepthTest) {
  auto& ctx = context();
  constexpr std::uint32_t kSize = 64;
  auto target = gauss::vk::OffscreenTarget::create(ctx, kSize, kSize, "triangles");
  ASSERT_TRUE(target) << target.message();
  // Red triangle at depth 0.25 covering the left half, green at depth 0.75 covering
  // all: drawn green last, red must still win where they overlap.
  const Vertex vertices[] = {
      {{-1, -1, 0.25f, 1}, {1, 0, 0, 1}}, {{0, -1, 0.25f, 1}, {1, 0, 0, 1}}, {{-1, 3, 0.25f, 1}, {1, 0, 0, 1}},
      {{-1, -1, 0.75f, 1}, {0, 1, 0, 1}}, {{3, -1, 0.75f, 1}, {0, 1, 0, 1}}, {{-1, 3, 0.75f, 1}, {0, 1, 0, 1}},
  };
  auto vbo = gauss::vk::Buffer::create(ctx, {.size = sizeof(vertices), .usage = VK_BUFFER_USAGE_VERTEX_BUFFER_BIT,
                                             .name = "triangle vertices"});
  ASSERT_TRUE(vbo) << vbo.message();
  ASSERT_TRUE(vbo->upload(vertices, sizeof(vertices)));
  auto pipeline = gauss::vk::GraphicsPipeline::create(
      ctx, {.name = "triangles",
            .vertex_shader = gauss::vk::spirv(gauss_spv_test_triangle_vert),
            .fragment_shader = gauss::vk::spirv(gauss_spv_test_triangle_frag),
            .vertex_stride = sizeof(Vertex),
            .attributes = {{0, VK_FORMAT_R32G32B32A32_SFLOAT, 0}, {1, VK_FORMAT_R32G32B32A32_SFLOAT, 16}},
            .depth_compare = VK_COMPARE_OP_LESS});
  ASSERT_TRUE(pipeline) << pipeline.message();

  gauss::Status bound = gauss::Ok{};
  auto st = ctx.submit_and_wait([&](VkCommandBuffer cmd) {
    gauss::vk::transfer_to_graphics_barrier(cmd);
    target->begin_rendering(cmd, true);
    bound = pipeline->bind(cmd, std::span<const gauss::vk::Resource>{});
    const VkDeviceSize offset = 0;
    const VkBuffer handle = vbo->handle();
    vkCmdBindVertexBuffers(cmd, 0, 1, &handle, &offset);
    vkCmdDraw(cmd, 3, 1, 0, 0);  // red, near
    vkCmdDraw(cmd, 3, 1, 3, 0);  // green, far
    target->end_rendering(cmd);
  });
  ASSERT_TRUE(st) << st.message();
  ASSERT_TRUE(bound) << bound.message();
  auto img = target->read_color(ctx);
  ASSERT_TRUE(img) << img.message();
  auto px = [&](std::uint32_t x, std::uint32_t y) { return &img->pixels[(y * kSize + x) * 4]; };
  // Left quarter: inside the red triangle (x < 0 in NDC, and near).
  EXPECT_EQ(px(8, 32)[0], 255);
  EXPECT_EQ(px(8, 32)[1], 0);
  // Right half: only green.
  EXPECT_EQ(px(48, 32)[0], 0);
  EXPECT_EQ(px(48, 32)[1], 255);
  auto depth = target->read_depth(ctx);
  ASSERT_TRUE(depth) << depth.message();
  EXPECT_EQ((*depth)[32 * kSize + 8], 0.25f);
  EXPECT_EQ((*depth)[32 * kSize + 48], 0.75f);
}

TEST_F(VkOffscreenTest, InvalidSizesAreErrors) {
  EXPECT_FALSE(gauss::vk::OffscreenTarget::create(context(), 0, 16));
  const std::uint32_t too_big = context().limits().maxImageDimension2D + 1;
  auto t = gauss::vk::OffscreenTarget::create(context(), too_big, 4, "huge");
  ASSERT_FALSE(t);
  EXPECT_NE(t.message().find("huge"), std::string::npos) << t.message();
}

}  // namespace
