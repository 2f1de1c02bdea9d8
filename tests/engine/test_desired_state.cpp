// DesiredState: latest-value coalescing, rejections that leave state untouched,
// resync, the Gaussian published epoch, and a property test against a reference model.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <random>

#include "gauss/engine/desired_state.h"
#include "gauss/engine/publisher.h"
#include "gauss/engine/slot_table.h"

using namespace gauss;

namespace {

Gaussian val(float x) {
  Gaussian g;
  g.position = {x, 0.0f, 1.0f};
  return g;
}
Edit ins(std::uint64_t id, float x) { return Edit{EditKind::Insert, GaussianId{id}, GaussianId{0}, val(x)}; }
Edit upd(std::uint64_t id, float x) { return Edit{EditKind::Update, GaussianId{id}, GaussianId{0}, val(x)}; }
Edit rem(std::uint64_t id) { return Edit{EditKind::Remove, GaussianId{id}, GaussianId{0}, {}}; }
Edit rep(std::uint64_t leaving, std::uint64_t id, float x) {
  return Edit{EditKind::Replace, GaussianId{id}, GaussianId{leaving}, val(x)};
}
EditBatch batch(std::uint64_t epoch, std::vector<Edit> edits) { return EditBatch{Epoch{epoch}, std::move(edits)}; }

// Publishes everything pending (immediate mode).
void publish_all(DesiredState& d, SlotTable& t) {
  Publisher p(PublisherConfig{.mode = PublishMode::Immediate});
  auto r = p.publish(d, t, ViewState{}, 0.0);
  ASSERT_TRUE(r.ok()) << r.message();
}

}  // namespace

TEST(DesiredState, NewerValueReplacesPendingOne) {
  DesiredState d(8);
  ASSERT_TRUE(d.apply(batch(1, {ins(1, 1.0f)}), 0.0).ok());
  ASSERT_TRUE(d.apply(batch(2, {upd(1, 2.0f)}), 0.1).ok());
  ASSERT_TRUE(d.apply(batch(3, {upd(1, 3.0f)}), 0.2).ok());
  EXPECT_EQ(d.pending_count(), 1u);
  const DesiredEntry* e = d.find(GaussianId{1});
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->pending_kind(), PendingKind::Insert);  // still an insert, now with the newest value
  EXPECT_EQ(e->value.position.x, 3.0f);
  EXPECT_EQ(e->pending_since, 0.0);  // age counts from the first pending edit
  EXPECT_EQ(to_underlying(e->epoch), 3u);
  EXPECT_EQ(d.stats().superseded, 2u);
  EXPECT_TRUE(d.check().ok()) << d.check().message();
}

TEST(DesiredState, RemoveAfterPendingInsertCancelsBoth) {
  DesiredState d(8);
  ASSERT_TRUE(d.apply(batch(1, {ins(1, 1.0f), ins(2, 2.0f)}), 0.0).ok());
  ASSERT_TRUE(d.apply(batch(2, {rem(1)}), 0.0).ok());
  EXPECT_EQ(d.find(GaussianId{1}), nullptr);
  EXPECT_EQ(d.pending_count(), 1u);
  EXPECT_EQ(d.desired_count(), 1u);
  EXPECT_EQ(d.stats().cancelled, 1u);
  // The id may come back later (the host would use a new id; the state must not care).
  ASSERT_TRUE(d.apply(batch(3, {ins(1, 5.0f)}), 0.0).ok());
  EXPECT_EQ(d.find(GaussianId{1})->pending_kind(), PendingKind::Insert);
  EXPECT_TRUE(d.check().ok());
}

TEST(DesiredState, RemoveThenInsertOfPublishedIdBecomesUpdate) {
  DesiredState d(8);
  auto t = SlotTable::create(8).value();
  ASSERT_TRUE(d.apply(batch(1, {ins(1, 1.0f)}), 0.0).ok());
  publish_all(d, t);
  ASSERT_TRUE(d.apply(batch(2, {rem(1)}), 0.0).ok());
  EXPECT_EQ(d.find(GaussianId{1})->pending_kind(), PendingKind::Remove);
  ASSERT_TRUE(d.apply(batch(3, {ins(1, 4.0f)}), 0.0).ok());
  EXPECT_EQ(d.find(GaussianId{1})->pending_kind(), PendingKind::Update);
  publish_all(d, t);
  EXPECT_EQ(t.records()[to_underlying(t.slot_of(GaussianId{1}))].position.x, 4.0f);
  EXPECT_EQ(d.pending_count(), 0u);
}

TEST(DesiredState, BadEditsAreRejectedCountedAndLeaveStateUntouched) {
  DesiredState d(2);
  ASSERT_TRUE(d.apply(batch(1, {ins(1, 1.0f)}), 0.0).ok());
  const std::uint64_t before = d.desired_checksum();
  Edit nan_edit = upd(1, 0.0f);
  nan_edit.value.opacity_logit = std::numeric_limits<float>::quiet_NaN();
  auto r = d.apply(batch(2, {upd(99, 1.0f), rem(98), ins(1, 7.0f), nan_edit, rep(97, 5, 1.0f)}), 0.0);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->accepted, 0u);
  EXPECT_EQ(r->rejected, 5u);
  EXPECT_NE(r->first_rejection.find("99"), std::string::npos);
  EXPECT_EQ(d.stats().rejected_unknown_id, 3u);
  EXPECT_EQ(d.stats().rejected_duplicate, 1u);
  EXPECT_EQ(d.stats().rejected_bad_value, 1u);
  EXPECT_EQ(d.desired_checksum(), before);
  EXPECT_EQ(d.find(GaussianId{1})->value.position.x, 1.0f);
  EXPECT_TRUE(d.check().ok());
}

TEST(DesiredState, CapacityIsNeverExceeded) {
  DesiredState d(2);
  auto r = d.apply(batch(1, {ins(1, 1.0f), ins(2, 2.0f), ins(3, 3.0f)}), 0.0);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->rejected, 1u);
  EXPECT_EQ(d.stats().rejected_capacity, 1u);
  EXPECT_EQ(d.desired_count(), 2u);
  // Removes first (the codec's order) or Replace keep a full budget usable.
  ASSERT_TRUE(d.apply(batch(2, {rem(1), ins(3, 3.0f)}), 0.0).ok());
  ASSERT_TRUE(d.apply(batch(3, {rep(2, 4, 4.0f)}), 0.0).ok());
  EXPECT_EQ(d.desired_count(), 2u);
  EXPECT_EQ(d.stats().rejected_capacity, 1u);
  EXPECT_TRUE(d.check().ok());
}

TEST(DesiredState, BatchWithEarlierEpochIsRefused) {
  DesiredState d(4);
  auto t = SlotTable::create(4).value();
  ASSERT_TRUE(d.apply(batch(5, {ins(1, 1.0f)}), 0.0).ok());
  auto back = d.apply(batch(3, {ins(2, 1.0f)}), 0.0);
  ASSERT_FALSE(back.ok());
  EXPECT_NE(back.message().find("epoch 3"), std::string::npos);
  EXPECT_EQ(d.stats().rejected_batches, 1u);
  EXPECT_EQ(d.desired_count(), 1u);
  publish_all(d, t);
  EXPECT_EQ(d.published_epoch(), Epoch{5});
  // A selection-only batch of the same epoch is accepted and does not move the
  // published epoch back (its records are of epoch 5 too).
  ASSERT_TRUE(d.apply(batch(5, {ins(2, 1.0f)}), 0.0).ok());
  EXPECT_EQ(d.pending_count(), 1u);
  EXPECT_EQ(d.published_epoch(), Epoch{5});
}

TEST(DesiredState, PublishedEpochFollowsPendingEdits) {
  DesiredState d(8);
  auto t = SlotTable::create(8).value();
  EXPECT_FALSE(d.published_epoch().has_value());
  ASSERT_TRUE(d.apply(batch(1, {ins(1, 1.0f), ins(2, 1.0f)}), 0.0).ok());
  // Epoch 1 is not published; epoch 0 is, vacuously (batches arrive in epoch order).
  EXPECT_EQ(d.published_epoch(), Epoch{0});
  publish_all(d, t);
  EXPECT_EQ(d.published_epoch(), Epoch{1});
  ASSERT_TRUE(d.apply(batch(2, {upd(1, 2.0f)}), 0.0).ok());
  ASSERT_TRUE(d.apply(batch(3, {upd(2, 2.0f)}), 0.0).ok());
  EXPECT_EQ(d.published_epoch(), Epoch{1});
  // Superseding epoch 2's pending edit by epoch 4 completes epoch 2 (and 3 is pending).
  ASSERT_TRUE(d.apply(batch(4, {upd(1, 3.0f)}), 0.0).ok());
  EXPECT_EQ(d.published_epoch(), Epoch{2});
  ASSERT_TRUE(d.apply(batch(5, {}), 0.0).ok());  // empty batches advance the received epoch
  publish_all(d, t);
  EXPECT_EQ(d.published_epoch(), Epoch{5});
}

TEST(DesiredState, ResyncKeepsEqualRecordsAndDropsTheRest) {
  DesiredState d(4);
  auto t = SlotTable::create(4).value();
  ASSERT_TRUE(d.apply(batch(1, {ins(1, 1.0f), ins(2, 2.0f), ins(3, 3.0f)}), 0.0).ok());
  publish_all(d, t);
  (void)t.take_dirty_ranges();
  // After a reconnect the host resends its complete desired set: 1 same, 2 changed, 3 gone, 4 new.
  auto r = d.apply_resync(batch(7, {ins(1, 1.0f), ins(2, 9.0f), ins(4, 4.0f), ins(4, 4.0f)}), 1.0);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->rejected, 1u);  // id 4 twice
  EXPECT_EQ(d.pending_count(), 3u);  // update 2, remove 3, insert 4: id 1 untouched
  EXPECT_EQ(d.find(GaussianId{1})->pending_kind(), PendingKind::None);
  EXPECT_FALSE(d.published_epoch().has_value() && to_underlying(*d.published_epoch()) >= 7u);
  publish_all(d, t);
  EXPECT_EQ(d.published_epoch(), Epoch{7});
  EXPECT_EQ(d.desired_count(), 3u);
  EXPECT_FALSE(t.contains(GaussianId{3}));
  EXPECT_EQ(t.slot_of(GaussianId{1}), SlotIndex{0});  // kept its slot: no flicker on reconnect
  EXPECT_TRUE(d.check().ok());
}

// Reference model: a map of the desired set; after publishing everything, the slot
// table must hold exactly that map. Random batches with bad edits mixed in, random
// partial publication between them.
namespace {

// Random batches of up to `max_edits` edits against a std::map model, publishing
// progressively in between; the end state must equal the model exactly. Batches longer
// than DesiredState::apply's prefetch distance (16 edits) exercise its software
// pipeline, including ids edited again (cancelled, re-inserted) within that distance.
void property_run(std::uint64_t first_seed, int seeds, int max_edits, std::uint32_t max_cap) {
  for (std::uint64_t seed = first_seed; seed < first_seed + static_cast<std::uint64_t>(seeds); ++seed) {
    std::mt19937_64 rng(seed);
    const std::uint32_t cap = 1 + static_cast<std::uint32_t>(rng() % max_cap);
    DesiredState d(cap);
    auto t = SlotTable::create(cap).value();
    Publisher pub(PublisherConfig{.mode = PublishMode::Progressive, .allowance_min = 1, .allowance_max = 3, .allowance_initial = 2});
    std::map<std::uint64_t, float> model;
    std::uint64_t next = 1;
    for (std::uint64_t epoch = 1; epoch <= 60; ++epoch) {
      std::vector<Edit> edits;
      std::map<std::uint64_t, float> after = model;
      const int n = static_cast<int>(rng() % static_cast<std::uint64_t>(max_edits));
      std::vector<std::uint64_t> removed;
      for (int k = 0; k < n; ++k) {
        const float x = static_cast<float>(rng() % 1000);
        const int op = static_cast<int>(rng() % 6);
        if (op == 0 && after.size() < cap) {
          edits.push_back(ins(next, x));
          after[next++] = x;
        } else if (op == 5 && !removed.empty() && after.size() < cap) {
          // Re-insert an id removed earlier in this batch: a pending insert cancelled
          // and its entry released, or a published id's remove superseded.
          const std::uint64_t id = removed.back();
          removed.pop_back();
          if (after.count(id)) continue;
          edits.push_back(ins(id, x));
          after[id] = x;
        } else if (op == 1 && !after.empty()) {
          auto it = std::next(after.begin(), static_cast<long>(rng() % after.size()));
          edits.push_back(upd(it->first, x));
          it->second = x;
        } else if (op == 2 && !after.empty()) {
          auto it = std::next(after.begin(), static_cast<long>(rng() % after.size()));
          edits.push_back(rem(it->first));
          removed.push_back(it->first);
          after.erase(it);
        } else if (op == 3 && !after.empty()) {
          auto it = std::next(after.begin(), static_cast<long>(rng() % after.size()));
          edits.push_back(rep(it->first, next, x));
          after.erase(it);
          after[next++] = x;
        } else {
          edits.push_back(upd(1000000 + rng() % 5, x));  // never inserted: rejected
        }
      }
      ASSERT_TRUE(d.apply(batch(epoch, edits), static_cast<double>(epoch)).ok());
      model = after;
      ASSERT_TRUE(d.check().ok()) << "seed " << seed << ": " << d.check().message();
      ASSERT_EQ(d.desired_count(), model.size());
      ASSERT_LE(d.desired_count(), cap);
      if (rng() % 2) {
        auto r = pub.publish(d, t, ViewState{}, static_cast<double>(epoch));
        ASSERT_TRUE(r.ok()) << r.message();
        ASSERT_TRUE(t.check().ok());
        ASSERT_EQ(t.size(), d.published_count());
      }
    }
    publish_all(d, t);
    ASSERT_EQ(t.size(), model.size()) << "seed " << seed;
    std::uint64_t model_sum = 0, slot_sum = 0;
    for (const auto& [id, x] : model) {
      const SlotIndex s = t.slot_of(GaussianId{id});
      ASSERT_NE(s, kNoSlot) << "seed " << seed << " id " << id;
      ASSERT_EQ(t.records()[to_underlying(s)].position.x, x);
      model_sum += record_hash(GaussianId{id}, val(x));
      slot_sum += record_hash(GaussianId{id}, t.records()[to_underlying(s)]);
    }
    EXPECT_EQ(model_sum, slot_sum);
    EXPECT_EQ(d.desired_checksum(), model_sum);
    EXPECT_EQ(d.published_epoch(), Epoch{60});
  }
}

}  // namespace

TEST(DesiredState, PropertyMatchesReferenceModel) { property_run(1, 40, 8, 40); }

TEST(DesiredState, PropertyMatchesReferenceModelInLargeBatches) { property_run(100, 20, 400, 64); }

// gaussian_is_finite checks the record's floats as one block of exponent bits: a NaN
// or infinity in any float field is caught, every finite value (zero, -0, denormals,
// the largest float) passes.
TEST(DesiredState, NonFiniteValueInAnyFloatFieldIsRejected) {
  const float bad[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                       -std::numeric_limits<float>::infinity()};
  const float good[] = {0.0f, -0.0f, std::numeric_limits<float>::denorm_min(), std::numeric_limits<float>::max(),
                        -std::numeric_limits<float>::max()};
  std::vector<float*(*)(Gaussian&)> fields = {
      [](Gaussian& g) { return &g.position.x; },       [](Gaussian& g) { return &g.position.z; },
      [](Gaussian& g) { return &g.log_scale.y; },      [](Gaussian& g) { return &g.rotation[0]; },
      [](Gaussian& g) { return &g.rotation[3]; },      [](Gaussian& g) { return &g.opacity_logit; },
      [](Gaussian& g) { return &g.sh_dc.z; },          [](Gaussian& g) { return &g.sh_rest[0].x; },
      [](Gaussian& g) { return &g.sh_rest[kMaxShRest - 1].z; }};
  for (auto field : fields) {
    for (float v : bad) {
      Gaussian g = val(1.0f);
      *field(g) = v;
      EXPECT_FALSE(gaussian_is_finite(g));
    }
    for (float v : good) {
      Gaussian g = val(1.0f);
      *field(g) = v;
      EXPECT_TRUE(gaussian_is_finite(g));
    }
  }
  // Non-float fields hold any bits.
  Gaussian g = val(1.0f);
  g.id = GaussianId{~std::uint64_t{0} - 1};
  g.support = 0xFFFFFFFFu;
  g.object = ObjectId{-1};
  EXPECT_TRUE(gaussian_is_finite(g));
}

// The flat id index against std::map over random inserts, overwrites and erases
// (backward-shift deletion must keep every remaining key findable).
TEST(DesiredState, IdIndexMatchesAReferenceMap) {
  std::mt19937_64 rng(99);
  detail::IdIndex idx;
  std::map<std::uint64_t, std::uint32_t> ref;
  for (int step = 0; step < 200000; ++step) {
    // Dense and clustered keys collide in runs: the hard case for linear probing.
    const std::uint64_t key = (rng() % 3 == 0) ? rng() : rng() % 5000;
    if (key == detail::IdIndex::kEmpty) continue;
    if (rng() % 3 == 0) {
      idx.erase(key);
      ref.erase(key);
    } else {
      const auto v = static_cast<std::uint32_t>(rng());
      idx.set(key, v);
      ref[key] = v;
    }
    if (step % 20000 == 0) {
      ASSERT_EQ(idx.size(), ref.size());
      for (const auto& [k, v] : ref) {
        const std::uint32_t* f = idx.find(k);
        ASSERT_NE(f, nullptr) << k;
        ASSERT_EQ(*f, v);
      }
      std::size_t n = 0;
      idx.for_each([&](std::uint64_t k, std::uint32_t v) {
        ++n;
        ASSERT_EQ(ref.at(k), v);
      });
      ASSERT_EQ(n, ref.size());
    }
  }
  EXPECT_EQ(idx.find(123456789012345ull), nullptr);
}

TEST(DesiredState, PendingArrivalsListNewAndChangedEntriesOnce) {
  DesiredState d(4);
  ASSERT_TRUE(d.apply(batch(1, {ins(1, 0.0f), ins(2, 1.0f)}), 0.0).ok());
  PendingArrivals got;
  got.overflowed = true;
  d.take_pending_arrivals(got);
  EXPECT_FALSE(got.overflowed);
  EXPECT_TRUE(got.removes.empty());
  ASSERT_EQ(got.others.size(), 2u);
  EXPECT_EQ(got.others[0].id, GaussianId{1});
  EXPECT_EQ(d.entry(got.others[0].index).id, GaussianId{1});
  EXPECT_EQ(got.others[0].kind, PendingKind::Insert);
  EXPECT_EQ(got.others[0].slot, kNoSlot);
  EXPECT_FALSE(got.others[0].changed);
  EXPECT_EQ(got.others[1].id, GaussianId{2});
  EXPECT_EQ(got.others[1].position, d.entry(got.others[1].index).value.position);
  d.take_pending_arrivals(got);
  EXPECT_EQ(got.size(), 0u) << "taken arrivals are not listed again";
  // A pending entry that changes is listed as changed; cancelling lists nothing.
  ASSERT_TRUE(d.apply(batch(2, {upd(1, 5.0f), rem(2)}), 1.0).ok());
  d.take_pending_arrivals(got);
  ASSERT_EQ(got.others.size(), 1u);
  EXPECT_TRUE(got.removes.empty());
  EXPECT_TRUE(got.others[0].changed);
  EXPECT_EQ(got.others[0].id, GaussianId{1});
  EXPECT_EQ(got.others[0].since, 0.0) << "pending since its first edit";
}

TEST(DesiredState, PendingArrivalsListRemovesApartWithTheirSlot) {
  DesiredState d(4);
  ASSERT_TRUE(d.apply(batch(1, {ins(1, 2.0f)}), 0.0).ok());
  d.mark_published(static_cast<std::uint32_t>(d.find(GaussianId{1}) - &d.entry(0)), SlotIndex{3});
  PendingArrivals got;
  d.take_pending_arrivals(got);
  ASSERT_TRUE(d.apply(batch(2, {rem(1), ins(5, 1.0f)}), 1.0).ok());
  d.take_pending_arrivals(got);
  ASSERT_EQ(got.removes.size(), 1u);
  ASSERT_EQ(got.others.size(), 1u);
  EXPECT_EQ(got.removes[0].kind, PendingKind::Remove);
  EXPECT_EQ(got.removes[0].slot, SlotIndex{3});
  EXPECT_EQ(got.removes[0].position, d.find(GaussianId{1})->published_position);
  EXPECT_EQ(got.removes[0].support, 0u);
  EXPECT_EQ(got.others[0].id, GaussianId{5});
  // arrival_of describes a pending entry the same way.
  const PendingArrival again = d.arrival_of(got.removes[0].index);
  EXPECT_EQ(again.kind, PendingKind::Remove);
  EXPECT_EQ(again.slot, SlotIndex{3});
}

TEST(DesiredState, PendingArrivalsOverflowInsteadOfGrowingWithoutBound) {
  DesiredState d(2);
  // Insert and cancel the same ids over and over: the list would grow with every batch.
  std::uint64_t epoch = 1;
  for (int round = 0; round < 2000; ++round) {
    ASSERT_TRUE(d.apply(batch(epoch++, {ins(10 + round, 0.0f)}), 0.0).ok());
    ASSERT_TRUE(d.apply(batch(epoch++, {rem(10 + round)}), 0.0).ok());
  }
  PendingArrivals got;
  d.take_pending_arrivals(got);
  EXPECT_TRUE(got.overflowed);
  EXPECT_EQ(got.size(), 0u);
  ASSERT_TRUE(d.apply(batch(epoch++, {ins(1, 0.0f)}), 0.0).ok());
  d.take_pending_arrivals(got);
  EXPECT_FALSE(got.overflowed) << "the overflow is reported once";
  EXPECT_EQ(got.size(), 1u);
}
