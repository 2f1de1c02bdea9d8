// StagedUploads' compute scatter (render/src/vk/upload_scatter.h): a copy group of many
// regions applied by one dispatch lands exactly the bytes vkCmdCopyBuffer would, in the
// same order with the other groups; whatever it cannot take (unaligned bytes, a source
// without storage usage, bytes wider than a binding, no staging for the piece table) is
// copied instead, and the stats say which path each group took.
#include <algorithm>
#include <cstring>
#include <limits>
#include <memory>
#include <numeric>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/render/splat_renderer.h"
#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_frame_ring.h"
#include "gauss/render/vk_staged_uploads.h"
#include "split_mix_rng.h"
#include "splat_test_util.h"
#include "vk_test.h"

namespace gauss::test {
namespace {

constexpr std::uint32_t kNeverScatter = std::numeric_limits<std::uint32_t>::max();

// A device buffer and the bytes the CPU expects in it.
struct Target {
  vk::Buffer buffer;
  std::vector<std::uint8_t> model;
  void apply(VkDeviceSize offset, const std::uint8_t* data, VkDeviceSize size) {
    std::memcpy(model.data() + offset, data, size);
  }
};

class UploadScatter : public VkTest {
 protected:
  void SetUp() override {
    VkTest::SetUp();
    auto r = vk::FrameRing::create(context(), 2);
    ASSERT_TRUE(r.ok()) << r.message();
    ring_ = std::move(*r);
  }
  std::unique_ptr<vk::StagedUploads> uploads(const vk::StagedUploadsCreateInfo& info) {
    auto up = vk::StagedUploads::create(context(), *ring_, info);
    EXPECT_TRUE(up.ok()) << up.message();
    return up.ok() ? std::move(*up) : nullptr;
  }
  // A device buffer filled with a known pattern (so stray writes show), and its model.
  Target target(VkDeviceSize size, std::uint64_t seed, bool larger_than_binding = false) {
    Target t;
    auto b = vk::Buffer::create(context(), {.size = size, .name = "scatter test destination",
                                            .allow_larger_than_binding_range = larger_than_binding});
    EXPECT_TRUE(b.ok()) << b.message();
    if (!b.ok()) return t;
    t.buffer = std::move(*b);
    if (!larger_than_binding) {
      t.model.resize(size);
      SplitMixRng rng{seed};
      for (auto& v : t.model) v = static_cast<std::uint8_t>(rng.next());
      EXPECT_TRUE(t.buffer.upload(t.model.data(), size).ok());
    }
    return t;
  }
  // One frame: records what is queued, submits it and waits.
  void frame(vk::StagedUploads& up) {
    auto f = ring_->begin();
    ASSERT_TRUE(f.ok()) << f.message();
    up.record(f->cmd);
    ASSERT_TRUE(ring_->submit().ok());
    up.submitted();
    ASSERT_TRUE(ring_->wait_all().ok());
  }
  static void expect_model(const Target& t, VkDeviceSize offset = 0, VkDeviceSize size = 0) {
    if (size == 0) size = t.model.size() - offset;
    std::vector<std::uint8_t> got(size);
    ASSERT_TRUE(t.buffer.download(got.data(), size, offset).ok());
    for (VkDeviceSize i = 0; i < size; ++i)
      ASSERT_EQ(got[i], t.model[offset + i]) << "byte " << offset + i << " of " << t.model.size();
  }
  // Queues `size` random bytes at `offset` of `t` through the ring (write() or reserve()).
  static void stage(vk::StagedUploads& up, Target& t, VkDeviceSize offset, VkDeviceSize size, SplitMixRng& rng) {
    std::vector<std::uint8_t> data(size);
    for (auto& v : data) v = static_cast<std::uint8_t>(rng.next());
    if (rng.next() % 2 == 0) {
      ASSERT_TRUE(up.write(t.buffer, offset, data.data(), size).ok());
    } else {
      auto span = up.reserve(t.buffer, offset, size);
      ASSERT_TRUE(span.ok()) << span.message();
      std::memcpy(span->data(), data.data(), size);
    }
    t.apply(offset, data.data(), size);
  }
  // Three frames of ~2500 word-aligned writes over two buffers: mostly small and
  // scattered, some adjacent to the previous one, some longer than a piece, a few
  // rewriting bytes written earlier in the same frame (a new group behind a barrier).
  vk::StagedUploadStats random_writes(std::uint32_t scatter_min_regions, std::uint64_t seed) {
    auto up = uploads({.initial_bytes = 256 * 1024, .scatter_min_regions = scatter_min_regions});
    if (!up) return {};
    Target t[2] = {target(4 << 20, seed), target(4 << 20, seed + 1)};
    SplitMixRng rng{seed};
    for (int f = 0; f < 3; ++f) {
      struct Written {
        VkDeviceSize offset, size;
      };
      std::vector<Written> written[2];
      for (int i = 0; i < 2500; ++i) {
        const int b = rng.next() % 10 < 7 ? 0 : 1;
        const std::uint64_t kind = rng.next() % 100;
        const VkDeviceSize size = kind < 1 ? 4000 + 4 * (rng.next() % 1300)   // 1-3 pieces
                                  : kind < 15 ? 64 + 4 * (rng.next() % 240)   // up to 1 KiB
                                              : 4 + 4 * (rng.next() % 16);    // a few words
        const std::uint64_t where = rng.next() % 100;
        VkDeviceSize offset = 4 * (rng.next() % ((t[b].model.size() - size) / 4));
        if (where < 15 && !written[b].empty()) {  // right after the previous write
          offset = written[b].back().offset + written[b].back().size;
        } else if (where < 17 && !written[b].empty()) {  // into an earlier write's bytes
          const Written& w = written[b][rng.next() % written[b].size()];
          offset = w.offset + 4 * (rng.next() % (w.size / 4));
        }
        if (offset + size > t[b].model.size()) offset = t[b].model.size() - size;
        stage(*up, t[b], offset, size, rng);
        written[b].push_back({offset, size});
      }
      frame(*up);
      expect_model(t[0]);
      expect_model(t[1]);
    }
    return up->stats();
  }

  std::unique_ptr<vk::FrameRing> ring_;
};

TEST_F(UploadScatter, RandomWritesLandWithEveryGroupScattered) {
  const vk::StagedUploadStats s = random_writes(0, 11);
  EXPECT_EQ(s.copy_groups, 0u) << "every group is word aligned and fits a binding";
  EXPECT_EQ(s.copy_regions, 0u);
  EXPECT_GT(s.scatter_groups, 3u) << "rewrites in one frame start new groups";
  EXPECT_GT(s.scatter_pieces, s.scatter_regions) << "writes longer than a piece are split";
  EXPECT_EQ(s.scatter_dispatches, s.scatter_groups);
  EXPECT_EQ(s.scatter_fallbacks, 0u);
}

TEST_F(UploadScatter, RandomWritesLandWithTheScatterOff) {
  const vk::StagedUploadStats s = random_writes(kNeverScatter, 11);
  EXPECT_EQ(s.scatter_groups, 0u);
  EXPECT_EQ(s.scatter_fallbacks, 0u) << "below the threshold is no fallback";
  EXPECT_GT(s.copy_regions, 0u);
}

TEST_F(UploadScatter, RandomWritesLandWithCopiesAndScattersMixed) {
  const vk::StagedUploadStats s = random_writes(32, 12);
  EXPECT_GT(s.scatter_groups, 0u);
  EXPECT_GT(s.copy_groups, 0u) << "some groups stay under the threshold";
}

// Left at its default, the threshold is the device's (measured per device type, see
// vk_staged_uploads.h): one group a region short of it is copied, one at it scatters.
TEST_F(UploadScatter, TheDefaultThresholdIsTheDevicesOwn) {
  const std::uint32_t t = vk::device_scatter_min_regions(context());
  const bool cpu = context().properties().deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
  EXPECT_EQ(t, cpu ? vk::kCpuScatterMinRegions : vk::kGpuScatterMinRegions);
  auto up = uploads({});
  ASSERT_TRUE(up);
  Target under = target(64 * 1024, 13), at = target(64 * 1024, 14);
  SplitMixRng rng{15};
  for (VkDeviceSize k = 0; k + 1 < t; ++k) stage(*up, under, k * 128, 8, rng);
  for (VkDeviceSize k = 0; k < t; ++k) stage(*up, at, k * 128, 8, rng);
  frame(*up);
  expect_model(under);
  expect_model(at);
  EXPECT_EQ(up->stats().copy_regions, t - 1);
  EXPECT_EQ(up->stats().scatter_regions, t);
}

// A scatter, a copy, a scatter and a copy to overlapping bytes of one buffer, in one
// frame: each lands over the one before (compute -> transfer -> compute barriers).
TEST_F(UploadScatter, OrderHoldsAcrossCopiesAndScatters) {
  auto up = uploads({.scatter_min_regions = 32});
  ASSERT_TRUE(up);
  Target t = target(64 * 1024, 3);
  SplitMixRng rng{4};
  for (VkDeviceSize k = 0; k < 40; ++k) stage(*up, t, k * 64, 16, rng);      // group 1: scatter
  stage(*up, t, 0, 256, rng);                                                 // group 2: copy
  for (VkDeviceSize k = 0; k < 40; ++k) stage(*up, t, k * 64 + 8, 16, rng);  // group 3: scatter
  stage(*up, t, 8, 600, rng);                                                 // group 4: copy
  frame(*up);
  expect_model(t);
  EXPECT_EQ(up->stats().scatter_groups, 2u);
  EXPECT_EQ(up->stats().copy_groups, 2u);
  EXPECT_EQ(up->stats().copy_regions, 2u);
  EXPECT_EQ(up->stats().scatter_regions, 80u);
}

// The threshold counts regions; a region longer than a piece (4 KiB) is several pieces.
TEST_F(UploadScatter, StatsCountWhatWasRecorded) {
  auto up = uploads({.scatter_min_regions = 32});
  ASSERT_TRUE(up);
  Target under = target(64 * 1024, 5), at = target(64 * 1024, 6);
  SplitMixRng rng{7};
  for (VkDeviceSize k = 0; k < 31; ++k) stage(*up, under, k * 128, 8, rng);
  for (VkDeviceSize k = 0; k < 31; ++k) stage(*up, at, k * 128, 8, rng);
  stage(*up, at, 8192, 5000, rng);  // 2 pieces
  frame(*up);
  expect_model(under);
  expect_model(at);
  const vk::StagedUploadStats& s = up->stats();
  EXPECT_EQ(s.copy_groups, 1u);
  EXPECT_EQ(s.copy_regions, 31u);
  EXPECT_EQ(s.scatter_groups, 1u);
  EXPECT_EQ(s.scatter_regions, 32u);
  EXPECT_EQ(s.scatter_pieces, 33u);
  EXPECT_EQ(s.scatter_dispatches, 1u);
  EXPECT_EQ(s.scatter_fallbacks, 0u);
}

// copy_from a caller's storage buffer scatters, in order with ring writes before and after
// it; the same copies from a buffer without storage usage fall back to vkCmdCopyBuffer.
TEST_F(UploadScatter, CopyFromACallersBufferScattersOrFallsBack) {
  for (const bool storage : {true, false}) {
    SCOPED_TRACE(storage ? "source with storage usage" : "source without storage usage");
    auto up = uploads({.scatter_min_regions = 32});
    ASSERT_TRUE(up);
    Target t = target(1 << 20, 8);
    auto src = vk::Buffer::create(context(), {.size = 1 << 20,
                                              .usage = storage ? VkBufferUsageFlags{VK_BUFFER_USAGE_STORAGE_BUFFER_BIT}
                                                               : VkBufferUsageFlags{VK_BUFFER_USAGE_TRANSFER_SRC_BIT},
                                              .memory = vk::MemoryUsage::HostVisible,
                                              .name = "caller's pack buffer"});
    ASSERT_TRUE(src.ok()) << src.message();
    auto* src_bytes = static_cast<std::uint8_t*>(src->mapped());
    ASSERT_NE(src_bytes, nullptr);
    SplitMixRng rng{9};
    for (VkDeviceSize i = 0; i < src->size(); ++i) src_bytes[i] = static_cast<std::uint8_t>(rng.next());
    for (int i = 0; i < 50; ++i) stage(*up, t, 4 * (rng.next() % (t.model.size() / 4 - 64)), 4 * (1 + rng.next() % 60), rng);
    // 3000 regions in disjoint 256-byte cells of the destination, sources anywhere.
    std::vector<VkBufferCopy> regions;
    for (VkDeviceSize cell = 0; cell < 3000; ++cell) {
      const VkDeviceSize size = 4 * (1 + rng.next() % 32);
      const VkDeviceSize dst = cell * 256 + 4 * (rng.next() % ((256 - size) / 4 + 1));
      const VkDeviceSize from = 4 * (rng.next() % ((src->size() - size) / 4));
      regions.push_back({from, dst, size});
    }
    ASSERT_TRUE(up->copy_from(*src, t.buffer, regions).ok());
    for (const VkBufferCopy& r : regions) t.apply(r.dstOffset, src_bytes + r.srcOffset, r.size);
    for (int i = 0; i < 50; ++i) stage(*up, t, 256 * (rng.next() % 3000), 4 * (1 + rng.next() % 100), rng);
    frame(*up);
    expect_model(t);
    const vk::StagedUploadStats& s = up->stats();
    if (storage) {
      EXPECT_GE(s.scatter_groups, 2u) << "the copy_from group and the ring groups around it";
      EXPECT_EQ(s.copy_regions, 0u);
    } else {
      EXPECT_EQ(s.scatter_fallbacks, 1u);
      EXPECT_GE(s.copy_regions, 3000u);
    }
  }
}

// A group with one unaligned region is copied whole; an aligned group beside it scatters.
TEST_F(UploadScatter, AnUnalignedGroupFallsBackToCopies) {
  auto up = uploads({.scatter_min_regions = 32});
  ASSERT_TRUE(up);
  Target odd = target(64 * 1024, 10), even = target(64 * 1024, 11);
  SplitMixRng rng{12};
  for (VkDeviceSize k = 0; k < 100; ++k) stage(*up, odd, k * 256 + (k == 57 ? 2 : 0), k == 57 ? 6 : 8, rng);
  for (VkDeviceSize k = 0; k < 100; ++k) stage(*up, even, k * 256, 8, rng);
  frame(*up);
  expect_model(odd);
  expect_model(even);
  const vk::StagedUploadStats& s = up->stats();
  EXPECT_EQ(s.scatter_fallbacks, 1u);
  EXPECT_EQ(s.copy_regions, 100u);
  EXPECT_EQ(s.scatter_regions, 100u);
}

// A ring at its cap has no room for the piece table: the group is copied, nothing lost.
// Once the frame has released its bytes, the next group of the kind scatters.
TEST_F(UploadScatter, NoStagingForThePieceTableFallsBackToCopies) {
  auto up = uploads({.initial_bytes = 64 * 1024, .max_ring_bytes = 64 * 1024, .scatter_min_regions = 32});
  ASSERT_TRUE(up);
  Target t = target(256 * 1024, 13);
  SplitMixRng rng{14};
  // 900 writes of 60 bytes take 900 x 64 staging bytes; their 10800-byte table does not fit.
  for (VkDeviceSize k = 0; k < 900; ++k) stage(*up, t, k * 128, 60, rng);
  EXPECT_FALSE(up->reserve(t.buffer, 0, 128 * 1024).ok()) << "past the cap: refused, nothing queued";
  frame(*up);
  expect_model(t);
  EXPECT_EQ(up->stats().scatter_fallbacks, 1u);
  EXPECT_EQ(up->stats().copy_regions, 900u);
  EXPECT_EQ(up->stats().ring_grows, 0u);
  for (VkDeviceSize k = 0; k < 100; ++k) stage(*up, t, k * 128 + 64, 60, rng);
  frame(*up);
  expect_model(t);
  EXPECT_EQ(up->stats().scatter_groups, 1u);
  EXPECT_EQ(up->stats().copy_regions, 900u);
}

// The scatter binds windows around a group's bytes: a group inside one binding's range
// scatters wherever it lies in a larger buffer; one spanning more is copied.
TEST_F(UploadScatter, BytesWiderThanABindingFallBackToCopies) {
  auto up = uploads({.scatter_min_regions = 32, .scatter_max_binding_bytes = 64 * 1024});
  ASSERT_TRUE(up);
  Target inside = target(1 << 20, 15), across = target(1 << 20, 16);
  SplitMixRng rng{17};
  for (VkDeviceSize k = 0; k < 100; ++k) stage(*up, inside, 700 * 1024 + 4 + k * 600, 40, rng);
  for (VkDeviceSize k = 0; k < 100; ++k) stage(*up, across, k * 10000, 40, rng);
  frame(*up);
  expect_model(inside);
  expect_model(across);
  EXPECT_EQ(up->stats().scatter_groups, 1u);
  EXPECT_EQ(up->stats().scatter_fallbacks, 1u);
  EXPECT_EQ(up->stats().copy_regions, 100u);
}

// The same with a real buffer past maxStorageBufferRange (lavapipe: 128 MiB).
TEST_F(UploadScatter, ABufferPastTheDeviceRangeScattersOnlyWithinOneBinding) {
  const VkDeviceSize range = context().max_storage_buffer_range();
  if (range > (256u << 20)) GTEST_SKIP() << "a buffer past a " << range << "-byte binding range is too large for a test";
  auto up = uploads({.scatter_min_regions = 32});
  ASSERT_TRUE(up);
  Target big = target(range + (1 << 20), 0, /*larger_than_binding=*/true);
  ASSERT_TRUE(big.buffer.valid());
  // The model covers two 256 KiB windows: the first bytes and the last.
  const VkDeviceSize window = 256 * 1024, tail = big.buffer.size() - window;
  big.model.assign(big.buffer.size(), 0);
  ASSERT_TRUE(big.buffer.upload(big.model.data(), window, 0).ok());
  ASSERT_TRUE(big.buffer.upload(big.model.data() + tail, window, tail).ok());
  SplitMixRng rng{18};
  for (VkDeviceSize k = 0; k < 100; ++k) stage(*up, big, tail + k * 2048, 64, rng);  // one binding: scatter
  frame(*up);
  EXPECT_EQ(up->stats().scatter_groups, 1u);
  for (VkDeviceSize k = 0; k < 100; ++k) stage(*up, big, (k % 2 == 0 ? 0 : tail) + k * 2048 + 64, 64, rng);
  frame(*up);  // first and last bytes: more than one binding, copied
  EXPECT_EQ(up->stats().scatter_fallbacks, 1u);
  EXPECT_EQ(up->stats().copy_regions, 100u);
  expect_model(big, 0, window);
  expect_model(big, tail, window);
}

// Slot edits the way publication makes them (thousands of scattered one-slot runs, from
// the ring and from a caller's pack buffer, clears and tints among them) show the image
// of a renderer that never scatters, given the slots as contiguous runs.
TEST_F(UploadScatter, ScatteredSlotEditsShowWhatContiguousRunsShow) {
  const std::uint32_t n = 2000;
  const auto scene = procedural_scene(n, 1, 21);
  const Camera cam = forward_camera(160, 120);
  auto make = [&](std::uint32_t frames, std::uint32_t scatter_min_regions) {
    auto r = render::SplatRenderer::create(context(), {.capacity = n, .sh_degree = 1, .max_width = 160,
                                                       .max_height = 120, .frames_in_flight = frames,
                                                       .upload_scatter_min_regions = scatter_min_regions});
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.message());
    return r.ok() ? std::move(*r) : nullptr;
  };
  auto scattered = make(2, vk::kDeviceScatterMinRegions), contiguous = make(1, kNeverScatter);
  ASSERT_TRUE(scattered && contiguous);
  const render::SlotLayout layout = scattered->slot_layout();
  // Odd slots from a pack buffer, one run each; even slots written one by one, shuffled.
  auto pack = vk::Buffer::create(context(), {.size = VkDeviceSize{n} * layout.bytes_per_slot(),
                                             .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                             .memory = vk::MemoryUsage::HostVisible,
                                             .name = "test pack buffer"});
  ASSERT_TRUE(pack.ok()) << pack.message();
  auto* bytes = static_cast<std::byte*>(pack->mapped());
  const VkDeviceSize sh_base = VkDeviceSize{n} * layout.core_bytes();
  std::vector<std::uint8_t> good(n);
  std::vector<Gaussian> odd;
  for (std::uint32_t s = 1; s < n; s += 2) odd.push_back(scene[s]);
  render::pack_slots(layout, odd, bytes, bytes + sh_base, nullptr, good.data());
  std::vector<render::PackedSlotRun> runs;
  for (std::uint32_t i = 0; i < odd.size(); ++i)
    runs.push_back({2 * i + 1, 1, VkDeviceSize{i} * layout.core_bytes(), sh_base + VkDeviceSize{i} * layout.sh_bytes(), 0, i});
  ASSERT_TRUE(scattered->queue_packed_slots(*pack, layout, runs, good).ok());
  std::vector<std::uint32_t> even;
  for (std::uint32_t s = 0; s < n; s += 2) even.push_back(s);
  SplitMixRng rng{22};
  for (std::size_t i = even.size(); i > 1; --i) std::swap(even[i - 1], even[rng.next() % i]);
  for (std::uint32_t s : even) ASSERT_TRUE(scattered->write_slot(SlotIndex{s}, scene[s]).ok());
  for (std::uint32_t s = 0; s < n; s += 7) ASSERT_TRUE(scattered->clear_slot(SlotIndex{s}).ok());
  for (std::uint32_t s = 3; s < n; s += 11)
    ASSERT_TRUE(scattered->set_edit_tint(SlotIndex{s}, {render::EditTintKind::Added, 0}).ok());
  ASSERT_TRUE(scattered->render(cam).ok());

  ASSERT_TRUE(contiguous->write_slots(0, scene).ok());
  for (std::uint32_t s = 0; s < n; s += 7) ASSERT_TRUE(contiguous->clear_slot(SlotIndex{s}).ok());
  for (std::uint32_t s = 3; s < n; s += 11)
    ASSERT_TRUE(contiguous->set_edit_tint(SlotIndex{s}, {render::EditTintKind::Added, 0}).ok());
  ASSERT_TRUE(contiguous->render(cam).ok());

  EXPECT_GE(scattered->uploads().stats().scatter_groups, 4u) << "core, SH, edit words: many runs each";
  EXPECT_EQ(scattered->uploads().stats().scatter_fallbacks, 0u);
  EXPECT_EQ(contiguous->uploads().stats().scatter_groups, 0u);
  EXPECT_EQ(scattered->occupied_count(), contiguous->occupied_count());
  auto a = scattered->read_image();
  auto b = contiguous->read_image();
  ASSERT_TRUE(a.ok() && b.ok());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < a->pixels.size(); ++i) differ += a->pixels[i] != b->pixels[i];
  EXPECT_EQ(differ, 0u);
}

}  // namespace
}  // namespace gauss::test
