// SurfaceStage: rejections, latest-value per chunk, and the epoch barrier as a property
// over random interleavings of batch arrival, surface arrival and publication.
#include <gtest/gtest.h>

#include <random>

#include "gauss/engine/publisher.h"
#include "gauss/engine/surface_stage.h"

using namespace gauss;

namespace {
StagedChunk chunk(std::uint64_t id, std::uint64_t epoch, std::size_t tris = 1) {
  StagedChunk c;
  c.chunk_id = id;
  c.epoch = Epoch{epoch};
  for (std::size_t t = 0; t < tris; ++t) {
    const auto base = static_cast<std::uint32_t>(c.mesh.positions.size());
    for (int v = 0; v < 3; ++v) {
      c.mesh.positions.push_back({static_cast<float>(v), static_cast<float>(epoch), 0.0f});
      c.mesh.colors.push_back({1, 2, 3});
    }
    c.mesh.indices.insert(c.mesh.indices.end(), {base, base + 1, base + 2});
  }
  return c;
}
}  // namespace

TEST(SurfaceStage, RejectsMalformedAndStalePatches) {
  SurfaceStage s;
  StagedChunk bad = chunk(1, 3);
  bad.mesh.indices[2] = 77;
  auto r = s.offer(bad);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("out of range"), std::string::npos);
  bad = chunk(1, 3);
  bad.mesh.colors.pop_back();
  EXPECT_FALSE(s.offer(bad).ok());
  ASSERT_TRUE(s.offer(chunk(1, 3)).ok());
  EXPECT_TRUE(s.offer(chunk(1, 3)).ok());   // the same epoch again: a no-op
  EXPECT_EQ(s.stats().duplicates, 1u);
  EXPECT_FALSE(s.offer(chunk(1, 2)).ok());  // older
  ASSERT_TRUE(s.offer(chunk(1, 4)).ok());   // supersedes the pending epoch-3 patch
  EXPECT_EQ(s.stats().rejected_bad, 2u);
  EXPECT_EQ(s.stats().rejected_stale, 1u);
  EXPECT_EQ(s.stats().superseded, 1u);
  EXPECT_EQ(s.pending_count(), 1u);
}

TEST(SurfaceStage, CommitsOnlyBehindThePublishedGaussians) {
  SurfaceStage s;
  ASSERT_TRUE(s.offer(chunk(1, 2)).ok());
  ASSERT_TRUE(s.offer(chunk(2, 5)).ok());
  EXPECT_EQ(s.commit(std::nullopt), 0u);
  EXPECT_EQ(s.commit(Epoch{1}), 0u);
  EXPECT_EQ(s.commit(Epoch{3}), 1u);
  EXPECT_EQ(s.committed_epoch(), Epoch{2});
  EXPECT_EQ(s.commit(Epoch{5}), 1u);
  EXPECT_EQ(s.committed_epoch(), Epoch{5});
  // An empty mesh removes the chunk once its epoch is published.
  StagedChunk gone;
  gone.chunk_id = 1;
  gone.epoch = Epoch{6};
  ASSERT_TRUE(s.offer(gone).ok());
  EXPECT_EQ(s.commit(Epoch{6}), 1u);
  EXPECT_EQ(s.committed().count(1), 0u);
  EXPECT_FALSE(s.offer(chunk(1, 5)).ok());  // a stale patch cannot resurrect it
}

// Host: epochs 1..E, each with random Gaussian edits and random surface chunks. The two
// streams arrive interleaved at random (surface may overtake Gaussians), publication
// runs with a random small allowance. At every frame the barrier holds, and the
// published epoch matches a brute-force reference: every received edit of epochs <= e
// is published or superseded.
TEST(SurfaceStage, EpochBarrierHoldsOverRandomInterleavings) {
  for (std::uint64_t seed = 1; seed <= 300; ++seed) {
    std::mt19937_64 rng(seed);
    const std::uint32_t cap = 8 + static_cast<std::uint32_t>(rng() % 24);
    DesiredState d(cap);
    auto slots = SlotTable::create(cap).value();
    SurfaceStage surf;
    Publisher pub(PublisherConfig{.mode = PublishMode::Progressive, .allowance_min = 1, .allowance_max = 4,
                                  .allowance_initial = 1 + static_cast<std::uint32_t>(rng() % 4)});
    // Host side: generate all epochs up front.
    std::vector<EditBatch> batches;
    std::vector<StagedChunk> patches;
    std::vector<std::uint64_t> live;
    std::uint64_t next = 1;
    const std::uint64_t epochs = 5 + rng() % 20;
    for (std::uint64_t e = 1; e <= epochs; ++e) {
      EditBatch b{Epoch{e}, {}};
      const int n = static_cast<int>(rng() % 6);
      for (int k = 0; k < n; ++k) {
        Edit ed;
        ed.value.position = {static_cast<float>(rng() % 10), 0.0f, 1.0f};
        if (!live.empty() && rng() % 3 == 0) {
          const std::size_t at = rng() % live.size();
          ed.kind = EditKind::Remove;
          ed.id = GaussianId{live[at]};
          live.erase(live.begin() + static_cast<long>(at));
        } else if (!live.empty() && rng() % 2 == 0) {
          ed.kind = EditKind::Update;
          ed.id = GaussianId{live[rng() % live.size()]};
          bool dup = false;
          for (const auto& o : b.edits) dup |= o.id == ed.id;
          if (dup) continue;
        } else if (live.size() < cap) {
          ed.kind = EditKind::Insert;
          ed.id = GaussianId{next};
          live.push_back(next++);
        } else {
          continue;
        }
        b.edits.push_back(ed);
      }
      batches.push_back(b);
      if (rng() % 2) patches.push_back(chunk(rng() % 4, e));
    }
    // Reference: for each (epoch, id) edit received, done when published or superseded.
    struct Ref {
      std::uint64_t epoch;
      GaussianId id;
    };
    std::vector<Ref> received;
    std::size_t bi = 0, pi = 0;
    int frames = 0;
    while (bi < batches.size() || pi < patches.size() || d.pending_count() > 0 || surf.pending_count() > 0) {
      const int what = static_cast<int>(rng() % 4);
      if (what == 0 && bi < batches.size()) {
        ASSERT_TRUE(d.apply(batches[bi], frames).ok());
        for (const auto& ed : batches[bi].edits) received.push_back({to_underlying(batches[bi].epoch), ed.id});
        ++bi;
      } else if (what == 1 && pi < patches.size()) {
        (void)surf.offer(patches[pi++]);  // a superseded chunk id may be refused as stale: fine
      } else {
        auto r = pub.publish(d, slots, ViewState{}, frames);
        ASSERT_TRUE(r.ok());
        surf.commit(d.published_epoch());
        ++frames;
        // Barrier.
        if (surf.committed_epoch()) {
          ASSERT_TRUE(d.published_epoch().has_value()) << "seed " << seed;
          ASSERT_LE(to_underlying(*surf.committed_epoch()), to_underlying(*d.published_epoch())) << "seed " << seed;
        }
        // Reference published epoch: lowest epoch with an edit neither published nor superseded.
        std::uint64_t ref = d.received_epoch() ? to_underlying(*d.received_epoch()) : 0;
        for (std::size_t k = 0; k < received.size(); ++k) {
          const DesiredEntry* e = d.find(received[k].id);
          bool superseded = false;
          for (std::size_t j = k + 1; j < received.size() && !superseded; ++j)
            superseded = received[j].id == received[k].id && received[j].epoch > received[k].epoch;
          const bool open = !superseded && e && e->pending_kind() != PendingKind::None;
          if (open) ref = std::min(ref, received[k].epoch - 1);
        }
        if (d.received_epoch()) {
          ASSERT_TRUE(d.published_epoch().has_value());
          ASSERT_EQ(to_underlying(*d.published_epoch()), ref) << "seed " << seed << " frame " << frames;
        }
      }
      ASSERT_LT(frames, 100000);
    }
    EXPECT_EQ(d.published_epoch(), Epoch{epochs});
    EXPECT_EQ(surf.pending_count(), 0u);
  }
}

// After a resync of epoch e resent the surface, chunks it did not resend are removed:
// committed ones and pending ones alike, each behind the barrier at e; chunks it resent
// (same epoch again, or newer) and chunks already removed are left alone.
TEST(SurfaceStage, ResyncDropsWhatItDidNotResend) {
  SurfaceStage s;
  ASSERT_TRUE(s.offer(chunk(1, 2)).ok());
  ASSERT_TRUE(s.offer(chunk(2, 2)).ok());
  ASSERT_TRUE(s.offer(chunk(3, 2)).ok());
  ASSERT_EQ(s.commit(Epoch{2}), 3u);
  ASSERT_TRUE(s.offer(StagedChunk{3, Epoch{3}, {}}).ok());  // chunk 3 removed at 3
  ASSERT_EQ(s.commit(Epoch{3}), 1u);
  ASSERT_TRUE(s.offer(chunk(4, 4)).ok());  // pending, never committed
  // Resync at epoch 6 resends chunk 1 only.
  ASSERT_TRUE(s.offer(chunk(1, 6)).ok());
  EXPECT_EQ(s.drop_not_resent(Epoch{6}), 2u);  // chunks 2 (committed) and 4 (pending)
  EXPECT_EQ(s.stats().dropped_on_resync, 2u);
  EXPECT_EQ(s.commit(Epoch{5}), 0u);  // the barrier holds the removals too
  EXPECT_EQ(s.committed().size(), 2u);
  EXPECT_EQ(s.commit(Epoch{6}), 3u);
  ASSERT_EQ(s.committed().size(), 1u);
  EXPECT_EQ(s.committed().count(1), 1u);
  EXPECT_EQ(s.committed_epoch(), Epoch{6});
  EXPECT_EQ(s.drop_not_resent(Epoch{6}), 0u);  // idempotent
}
