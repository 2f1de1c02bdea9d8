// Frames in flight: FrameRing pacing and deferred destruction, StagedUploads ordering and
// growth, and a renderer with 2 frames in flight giving the very images of the blocking
// path while slots, tints and mesh chunks change between frames; slot runs packed into a
// caller's buffer (another thread's, in the client) land as the same writes would.
#include <array>
#include <cstring>
#include <functional>
#include <limits>
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
  auto up = vk::StagedUploads::create(context(), *r, {.initial_bytes = 64 * 1024});
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
  auto up = vk::StagedUploads::create(context(), *r, {.initial_bytes = 64 * 1024});
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

// Replaying recorded passes shows what recording them every frame shows, through every
// change a recording depends on (the camera, the high-water mark, tints, highlights, the
// mesh, culling, the view size) and frames in flight; a frame that changed none of them is
// replayed, one that changed any is recorded anew.
TEST_F(FramesInFlight, ReplayedPassesShowWhatFreshlyRecordedOnesShow) {
  const auto scene = procedural_scene(1500, 1, 9);
  auto make = [&](bool reuse) {
    auto r = render::SplatRenderer::create(context(), {.capacity = 1500, .sh_degree = 1, .max_width = 160,
                                                       .max_height = 120, .frames_in_flight = 2,
                                                       .reuse_recorded_passes = reuse});
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.message());
    return r.ok() ? std::move(*r) : nullptr;
  };
  auto reuse = make(true), fresh = make(false);
  ASSERT_TRUE(reuse && fresh);
  TriangleMesh wall;
  wall.positions = {{-3, -2, 9}, {3, -2, 9}, {0, 2, 9}};
  wall.colors.assign(3, {40, 160, 40});
  wall.indices = {0, 1, 2};
  const Camera near_cam = forward_camera(160, 120);
  const Camera moved = look_at_camera(160, 120, {0.3, -0.2, 0.0}, {0.0, 0.0, 8.0});
  const Camera small = forward_camera(120, 90);
  struct Step {
    const char* what;
    Camera cam;
    render::SplatRenderOptions options{};
    std::function<Status(render::SplatRenderer&)> change;
    bool replay_expected;  // nothing the recording depends on changed since the last step
  };
  const std::vector<Step> steps = {
      {"first slots", near_cam, {}, [&](auto& r) { return r.write_slots(0, std::span(scene).first(700)); }, false},
      {"camera moves", moved, {}, nullptr, true},
      {"more slots (high-water mark)", moved, {}, [&](auto& r) { return r.write_slots(700, std::span(scene).subspan(700, 800)); }, false},
      {"a slot rewritten below the mark", near_cam, {}, [&](auto& r) { return r.write_slots(3, std::span(scene).subspan(1400, 1)); }, true},
      {"edit tint", near_cam, {}, [&](auto& r) { return r.set_edit_tint(SlotIndex{5}, {render::EditTintKind::Added, 0}); }, false},
      {"tint cleared", near_cam, {}, [&](auto& r) { return r.set_edit_tints(0, 1500, {.kind = render::EditTintKind::None}); }, false},
      {"highlight", moved, {}, [&](auto& r) { const ObjectId ids[] = {ObjectId{1}}; return r.set_highlight(ids); }, false},
      {"highlight off", moved, {}, [&](auto& r) { return r.set_highlight({}); }, false},
      {"mesh", near_cam, {}, [&](auto& r) { return r.set_mesh(wall); }, false},
      {"exact culling off", near_cam, {.exact_culling = false}, nullptr, false},
      {"smaller view", small, {}, nullptr, false},
      {"back to the first size", near_cam, {}, nullptr, false},
      {"nothing changed", near_cam, {}, nullptr, true},
  };
  // With two frames in flight each frame slot keeps its own recording: after a change the
  // first two frames record (one per slot) and the third replays. Every frame's image is
  // compared.
  for (const Step& step : steps) {
    SCOPED_TRACE(step.what);
    if (step.change) {
      ASSERT_TRUE(step.change(*reuse).ok());
      ASSERT_TRUE(step.change(*fresh).ok());
    }
    for (int k = 0; k < 3; ++k) {
      SCOPED_TRACE("rendering " + std::to_string(k));
      auto a = reuse->render(step.cam, step.options);
      auto b = fresh->render(step.cam, step.options);
      ASSERT_TRUE(a.ok() && b.ok()) << (a.ok() ? b.message() : a.message());
      EXPECT_FALSE(b->passes_replayed);
      EXPECT_EQ(a->passes_replayed, step.replay_expected || k == 2);
      EXPECT_EQ(a->visible, b->visible);
      EXPECT_EQ(a->pairs, b->pairs);
      auto ia = reuse->read_image();
      auto ib = fresh->read_image();
      ASSERT_TRUE(ia.ok() && ib.ok());
      ASSERT_EQ(ia->pixels.size(), ib->pixels.size());
      std::size_t differ = 0;
      for (std::size_t i = 0; i < ia->pixels.size(); ++i) differ += ia->pixels[i] != ib->pixels[i];
      EXPECT_EQ(differ, 0u);
    }
  }
}

// Runs packed by pack_slots into a host-visible buffer and queued with queue_packed_slots
// show what write_slots shows, a non-finite Gaussian included (refused, counted, its slot
// left empty); and a later ring write to the same slots in the same frame still wins.
TEST_F(FramesInFlight, PackedSlotRunsLandAsWritesDo) {
  auto scene = procedural_scene(900, 1, 11);
  scene[17].position.x = std::numeric_limits<float>::quiet_NaN();
  const Camera cam = forward_camera(160, 120);
  auto packed = renderer(1000, 2);
  auto written = renderer(1000, 1);
  ASSERT_TRUE(packed && written);
  const render::SlotLayout layout = packed->slot_layout();
  EXPECT_EQ(layout.bytes_per_slot(), 64u + 3u * 3u * 4u) << "core record + SH band 1";
  auto source = vk::Buffer::create(context(), {.size = VkDeviceSize{900} * layout.bytes_per_slot(),
                                               .usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                               .memory = vk::MemoryUsage::HostVisible,
                                               .name = "test pack buffer"});
  ASSERT_TRUE(source.ok()) << source.message();
  auto* bytes = static_cast<std::byte*>(source->mapped());
  ASSERT_NE(bytes, nullptr);
  // Two runs, slots [0, 500) and [600, 1000), packed core area first, then the SH area.
  std::vector<std::uint8_t> good(900, 7);
  std::byte* sh = bytes + std::size_t{900} * layout.core_bytes();
  const std::uint32_t refused = render::pack_slots(layout, std::span(scene).first(900), bytes, sh, nullptr, good.data());
  EXPECT_EQ(refused, 1u);
  EXPECT_EQ(good[17], 0u);
  EXPECT_EQ(good[18], 1u);
  const VkDeviceSize sh_base = VkDeviceSize{900} * layout.core_bytes();
  const std::vector<render::PackedSlotRun> runs = {
      {0, 500, 0, sh_base, 0, 0},
      {600, 400, VkDeviceSize{500} * layout.core_bytes(), sh_base + VkDeviceSize{500} * layout.sh_bytes(), 0, 500}};
  ASSERT_TRUE(packed->queue_packed_slots(*source, layout, runs, good).ok());
  ASSERT_TRUE(packed->clear_slots(990, 10).ok());  // after the packed copies: stays clear
  EXPECT_EQ(packed->occupied_count(), 889u);
  EXPECT_EQ(packed->rejected_nonfinite(), 1u);
  ASSERT_TRUE(packed->render(cam).ok());

  ASSERT_TRUE(written->write_slots(0, std::span(scene).first(500)).ok());
  ASSERT_TRUE(written->write_slots(600, std::span(scene).subspan(500, 390)).ok());
  EXPECT_EQ(written->occupied_count(), 889u);
  ASSERT_TRUE(written->render(cam).ok());
  auto a = packed->read_image();
  auto b = written->read_image();
  ASSERT_TRUE(a.ok() && b.ok());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < a->pixels.size(); ++i) differ += a->pixels[i] != b->pixels[i];
  EXPECT_EQ(differ, 0u);
  EXPECT_EQ(packed->high_water(), written->high_water());
}

// queue_packed_slots refuses, queuing nothing: another layout, a run past the capacity,
// flags or bytes past what was given.
TEST_F(FramesInFlight, PackedSlotRunsAreCheckedBeforeAnythingIsQueued) {
  auto r = renderer(100, 2);
  ASSERT_TRUE(r);
  render::SlotLayout layout = r->slot_layout();
  auto source = vk::Buffer::create(context(), {.size = VkDeviceSize{10} * layout.bytes_per_slot(),
                                               .usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                               .memory = vk::MemoryUsage::HostVisible,
                                               .name = "test pack buffer"});
  ASSERT_TRUE(source.ok());
  const std::vector<std::uint8_t> good(10, 1);
  const VkDeviceSize sh = VkDeviceSize{10} * layout.core_bytes();
  const std::uint64_t regions = r->uploads().stats().writes;
  render::SlotLayout other = layout;
  other.sh_degree = 0;
  other.sh_stride = 0;
  auto st = r->queue_packed_slots(*source, other, std::vector<render::PackedSlotRun>{{0, 10, 0, sh, 0, 0}}, good);
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.message().find("another slot layout"), std::string::npos) << st.message();
  st = r->queue_packed_slots(*source, layout, std::vector<render::PackedSlotRun>{{95, 10, 0, sh, 0, 0}}, good);
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.message().find("exceed the capacity"), std::string::npos) << st.message();
  st = r->queue_packed_slots(*source, layout, std::vector<render::PackedSlotRun>{{0, 10, 0, sh, 0, 1}}, good);
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.message().find("flags"), std::string::npos) << st.message();
  st = r->queue_packed_slots(*source, layout, std::vector<render::PackedSlotRun>{{0, 10, 0, sh + 4, 0, 0}}, good);
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.message().find("past the end of 'test pack buffer'"), std::string::npos) << st.message();
  EXPECT_EQ(r->uploads().stats().writes, regions);
  EXPECT_EQ(r->occupied_count(), 0u);
}

}  // namespace
}  // namespace gauss::test
