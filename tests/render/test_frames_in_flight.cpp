// Frames in flight: FrameRing pacing and deferred destruction, StagedUploads ordering and
// growth, and a renderer with 2 frames in flight giving the very images of the blocking
// path while slots, tints and mesh chunks change between frames.
#include <cstring>
#include <numeric>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_commands.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_frame_ring.h"
#include "gauss/render/vk_staged_uploads.h"
#include "splat_test_util.h"
#include "vk_test.h"

namespace gauss::test {
namespace {

class FramesInFlight : public VkTest {
 protected:
  std::unique_ptr<vk::FrameRing> ring(std::uint32_t n) {
    auto r = vk::FrameRing::create(context(), n);
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.message());
    return r.ok() ? std::move(*r) : nullptr;
  }
  vk::Buffer buffer(VkDeviceSize size) {
    auto b = vk::Buffer::create(context(), {.size = size, .name = "test destination"});
    EXPECT_TRUE(b.ok());
    return b.ok() ? std::move(*b) : vk::Buffer{};
  }
  std::vector<std::uint8_t> download(const vk::Buffer& b) {
    std::vector<std::uint8_t> out(b.size());
    EXPECT_TRUE(b.download(out.data(), out.size()).ok());
    return out;
  }
  std::unique_ptr<render::SplatRenderer> renderer(std::uint32_t capacity, std::uint32_t frames) {
    auto r = render::SplatRenderer::create(context(), {.capacity = capacity, .sh_degree = 1, .max_width = 160,
                                                       .max_height = 120, .frames_in_flight = frames});
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.message());
    return r.ok() ? std::move(*r) : nullptr;
  }
};

TEST_F(FramesInFlight, RingRefusesBadCountsAndNumbersFramesInOrder) {
  EXPECT_FALSE(vk::FrameRing::create(context(), 0).ok());
  EXPECT_FALSE(vk::FrameRing::create(context(), vk::kMaxFramesInFlight + 1).ok());
  auto r = ring(2);
  ASSERT_TRUE(r);
  for (std::uint64_t k = 1; k <= 5; ++k) {
    auto f = r->begin();
    ASSERT_TRUE(f.ok()) << f.message();
    EXPECT_EQ(f->serial, k);
    EXPECT_EQ(f->index, k % 2);
    EXPECT_FALSE(r->begin().ok()) << "a second begin while recording";
    ASSERT_TRUE(r->submit().ok());
    // Never more than 2 frames outstanding: frame k - 2 has finished when k begins.
    EXPECT_GE(r->completed_serial() + 2, k);
  }
  EXPECT_FALSE(r->wait(6).ok()) << "waiting for a frame never submitted";
  ASSERT_TRUE(r->wait_all().ok());
  EXPECT_EQ(r->completed_serial(), 5u);
}

TEST_F(FramesInFlight, DeferredDestructionWaitsForTheFramesThatCouldUseTheObject) {
  auto r = ring(2);
  ASSERT_TRUE(r);
  std::uint64_t ran_when_completed = 0;
  bool ran = false;
  auto f = r->begin();
  ASSERT_TRUE(f.ok());
  r->defer([&] {
    ran = true;
    ran_when_completed = r->completed_serial();
  });
  ASSERT_TRUE(r->submit().ok());
  EXPECT_FALSE(ran) << "ran while its frame may still be in flight";
  ASSERT_TRUE(r->begin().ok());  // frame 2; frame 1 may or may not have finished
  ASSERT_TRUE(r->submit().ok());
  ASSERT_TRUE(r->wait_all().ok());
  EXPECT_TRUE(ran);
  EXPECT_GE(ran_when_completed, 1u);
}

TEST_F(FramesInFlight, OverlappingWritesLandInTheOrderTheyWereMade) {
  auto r = ring(2);
  ASSERT_TRUE(r);
  auto up = vk::StagedUploads::create(context(), *r, 64 * 1024);
  ASSERT_TRUE(up.ok()) << up.message();
  vk::Buffer dst = buffer(256);
  std::vector<std::uint8_t> a(128, 0xAA), b(64, 0xBB), c(16, 0xCC);
  ASSERT_TRUE((*up)->write(dst, 0, a.data(), a.size()).ok());
  ASSERT_TRUE((*up)->write(dst, 96, b.data(), b.size()).ok());   // overlaps a's tail
  ASSERT_TRUE((*up)->write(dst, 100, c.data(), c.size()).ok());  // overlaps b
  ASSERT_TRUE((*up)->write(dst, 200, c.data(), c.size()).ok());  // clear of all
  EXPECT_FALSE((*up)->write(dst, 250, c.data(), c.size()).ok()) << "past the end";
  auto f = r->begin();
  ASSERT_TRUE(f.ok());
  (*up)->record(f->cmd);
  ASSERT_TRUE(r->submit().ok());
  (*up)->submitted();
  ASSERT_TRUE(r->wait_all().ok());
  const auto got = download(dst);
  for (std::size_t i = 0; i < 256; ++i) {
    std::uint8_t want = 0;
    if (i < 96) want = 0xAA;
    if (i >= 96 && i < 160) want = 0xBB;
    if (i >= 100 && i < 116) want = 0xCC;
    if (i >= 200 && i < 216) want = 0xCC;
    if (i >= 160 && i < 200) want = 0;
    if (i >= 216) want = 0;
    if (want == 0) continue;  // the buffer's initial bytes are not specified
    ASSERT_EQ(got[i], want) << "byte " << i;
  }
  EXPECT_GE((*up)->stats().copy_groups, 3u) << "overlapping writes need their own copy groups";
}

TEST_F(FramesInFlight, TheRingWrapsAndGrowsWithoutLosingBytes) {
  auto r = ring(2);
  ASSERT_TRUE(r);
  auto up = vk::StagedUploads::create(context(), *r, 64 * 1024);
  ASSERT_TRUE(up.ok());
  vk::Buffer dst = buffer(1 << 20);
  std::vector<std::uint32_t> words((1 << 20) / 4);
  // 40 frames of 40 KiB each wrap a 64 KiB ring many times; then one 512 KiB write grows it.
  for (std::uint32_t frame = 0; frame < 41; ++frame) {
    const std::uint32_t bytes = frame < 40 ? 40 * 1024 : 512 * 1024;
    const std::uint32_t offset = frame < 40 ? (frame % 16) * 40 * 1024 : 0;
    std::vector<std::uint32_t> data(bytes / 4);
    std::iota(data.begin(), data.end(), frame * 1000003u);
    std::memcpy(reinterpret_cast<std::uint8_t*>(words.data()) + offset, data.data(), bytes);
    ASSERT_TRUE((*up)->write(dst, offset, data.data(), bytes).ok());
    auto f = r->begin();
    ASSERT_TRUE(f.ok());
    (*up)->record(f->cmd);
    ASSERT_TRUE(r->submit().ok());
    (*up)->submitted();
  }
  ASSERT_TRUE(r->wait_all().ok());
  EXPECT_GE((*up)->stats().ring_grows, 1u);
  const auto got = download(dst);
  EXPECT_EQ(std::memcmp(got.data(), words.data(), 640 * 1024), 0);
}

// Slot writes, clears, tints and mesh chunks changing between frames with 2 frames in
// flight end in the same image as the blocking renderer given the same final state.
TEST_F(FramesInFlight, PipelinedFramesEndInTheBlockingRenderersImage) {
  const auto scene = procedural_scene(1200, 1, 5);
  const Camera cam = forward_camera(160, 120);
  auto piped = renderer(1200, 2);
  auto blocking = renderer(1200, 1);
  ASSERT_TRUE(piped && blocking);
  TriangleMesh left, right;
  left.positions = {{-3, -2, 9}, {0, -2, 9}, {0, 2, 9}};
  left.colors = {{200, 30, 30}, {200, 30, 30}, {200, 30, 30}};
  left.indices = {0, 1, 2};
  right = left;
  for (auto& p : right.positions) p.x += 3.0f;
  right.colors.assign(3, {30, 30, 200});

  // Pipelined: the scene arrives in pieces over 6 frames, some slots are written twice
  // (the later write must win), a few cleared, chunks added, replaced and removed.
  std::vector<std::uint64_t> serials;
  for (int frame = 0; frame < 6; ++frame) {
    const std::size_t lo = frame * 200, hi = lo + 200;
    ASSERT_TRUE(piped->write_slots(static_cast<std::uint32_t>(lo), std::span(scene).subspan(lo, hi - lo)).ok());
    if (frame > 0) {  // rewrite the previous piece's first 10 slots with the same values
      ASSERT_TRUE(piped->clear_slots(static_cast<std::uint32_t>(lo - 200), 10).ok());
      ASSERT_TRUE(piped->write_slots(static_cast<std::uint32_t>(lo - 200), std::span(scene).subspan(lo - 200, 10)).ok());
    }
    Status chunk = Ok{};
    if (frame == 1) chunk = piped->set_mesh_chunk(7, right);
    if (frame == 2) chunk = piped->set_mesh_chunk(3, right);
    if (frame == 3) chunk = piped->set_mesh_chunk(3, left);  // replace
    ASSERT_TRUE(chunk.ok()) << chunk.message();
    if (frame == 4) piped->remove_mesh_chunk(99);                        // absent: nothing
    auto s = piped->render_frame(std::span<const Camera>(&cam, 1));
    ASSERT_TRUE(s.ok()) << s.message();
    serials.push_back(*s);
  }
  ASSERT_TRUE(piped->clear_slots(1190, 10).ok());
  ASSERT_TRUE(piped->set_edit_tint(SlotIndex{5}, {render::EditTintKind::Added, 0}).ok());
  ASSERT_TRUE(piped->render_frame(std::span<const Camera>(&cam, 1)).ok());
  // Every frame's statistics stay readable after its slot was reused.
  for (std::uint64_t s : serials) EXPECT_TRUE(piped->frame_stats(s).ok()) << "frame " << s;
  auto a = piped->read_image();
  ASSERT_TRUE(a.ok()) << a.message();

  ASSERT_TRUE(blocking->write_slots(0, std::span(scene).subspan(0, 1190)).ok());
  TriangleMesh both = left;  // chunks in id order: 3 (left) then 7 (right)
  for (std::size_t i = 0; i < right.positions.size(); ++i) {
    both.positions.push_back(right.positions[i]);
    both.colors.push_back(right.colors[i]);
  }
  both.indices = {0, 1, 2, 3, 4, 5};
  ASSERT_TRUE(blocking->set_mesh(both).ok());
  // The tint's age counts display frames: advance the blocking renderer to the same frame.
  for (int k = 0; k < 6; ++k) ASSERT_TRUE(blocking->render(cam).ok());
  ASSERT_TRUE(blocking->set_edit_tint(SlotIndex{5}, {render::EditTintKind::Added, 0}).ok());
  ASSERT_TRUE(blocking->render(cam).ok());
  auto b = blocking->read_image();
  ASSERT_TRUE(b.ok());
  ASSERT_EQ(a->pixels.size(), b->pixels.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < a->pixels.size(); ++i) differ += a->pixels[i] != b->pixels[i];
  EXPECT_EQ(differ, 0u);
  EXPECT_EQ(piped->mesh_chunk_count(), 2u);
  EXPECT_EQ(piped->occupied_count(), 1190u);
}

}  // namespace
}  // namespace gauss::test
