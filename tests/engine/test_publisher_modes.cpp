// Publisher: immediate vs progressive, allowance bound, view priority, age escape,
// slack-adaptive allowance, and the budget held during a full replacement.
#include <gtest/gtest.h>

#include <random>

#include "gauss/engine/publisher.h"

using namespace gauss;

namespace {

Edit ins(std::uint64_t id, glm::vec3 p) {
  Edit e{EditKind::Insert, GaussianId{id}, GaussianId{0}, {}};
  e.value.position = p;
  e.value.id = GaussianId{id};
  return e;
}

struct Fixture {
  explicit Fixture(std::uint32_t cap) : desired(cap), slots(SlotTable::create(cap).value()) {}
  DesiredState desired;
  SlotTable slots;
};

}  // namespace

TEST(Publisher, ImmediatePublishesEverything) {
  Fixture f(1000);
  std::vector<Edit> edits;
  for (std::uint64_t i = 0; i < 1000; ++i) edits.push_back(ins(i + 1, {0, 0, 1}));
  ASSERT_TRUE(f.desired.apply({Epoch{1}, edits}, 0.0).ok());
  Publisher p(PublisherConfig{.mode = PublishMode::Immediate});
  auto r = p.publish(f.desired, f.slots, {}, 0.0);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->inserted, 1000u);
  EXPECT_EQ(r->allowance, PublisherConfig{}.immediate_allowance);
  EXPECT_EQ(f.desired.pending_count(), 0u);
  EXPECT_EQ(f.slots.size(), 1000u);
}

TEST(Publisher, ProgressiveRespectsAllowanceAndPrefersTheView) {
  Fixture f(200);
  std::vector<Edit> edits;
  // 100 Gaussians ahead of the viewer (+z), 100 behind.
  for (std::uint64_t i = 0; i < 100; ++i) edits.push_back(ins(i + 1, {0, 0, 2}));
  for (std::uint64_t i = 0; i < 100; ++i) edits.push_back(ins(i + 101, {0, 0, -2}));
  ASSERT_TRUE(f.desired.apply({Epoch{1}, edits}, 0.0).ok());
  Publisher p(PublisherConfig{.mode = PublishMode::Progressive, .allowance_min = 10, .allowance_max = 50, .allowance_initial = 50});
  auto r = p.publish(f.desired, f.slots, ViewState{{0, 0, 0}, {0, 0, 1}}, 0.0);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->slot_writes(), 50u);
  for (std::uint64_t i = 101; i <= 200; ++i) EXPECT_FALSE(f.slots.contains(GaussianId{i})) << i;
  // Turning around flips the preference.
  r = p.publish(f.desired, f.slots, ViewState{{0, 0, 0}, {0, 0, -1}}, 0.0);
  ASSERT_TRUE(r.ok());
  int behind = 0;
  for (std::uint64_t i = 101; i <= 200; ++i) behind += f.slots.contains(GaussianId{i});
  EXPECT_EQ(behind, 50);
  EXPECT_EQ(f.slots.size(), 100u);
}

TEST(Publisher, AgeEscapeServesOldLowPriorityEdits) {
  Fixture f(100);
  ASSERT_TRUE(f.desired.apply({Epoch{1}, {ins(1, {0, 0, -50})}}, 0.0).ok());  // far behind: lowest priority
  std::vector<Edit> fresh;
  for (std::uint64_t i = 0; i < 50; ++i) fresh.push_back(ins(i + 2, {0, 0, 1}));
  ASSERT_TRUE(f.desired.apply({Epoch{2}, fresh}, 0.9).ok());
  PublisherConfig cfg{.mode = PublishMode::Progressive, .allowance_min = 5, .allowance_max = 5, .allowance_initial = 5};
  cfg.age_escape_s = 0.5;
  cfg.w_age = 0.0f;  // only the escape can serve it
  Publisher p(cfg);
  auto r = p.publish(f.desired, f.slots, ViewState{{0, 0, 0}, {0, 0, 1}}, 1.0);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->escaped, 1u);
  EXPECT_TRUE(f.slots.contains(GaussianId{1}));
  EXPECT_EQ(r->slot_writes(), 6u);  // allowance plus the escaped edit
  // Without the escape the old edit waits behind the fresh ones.
  Fixture g(100);
  ASSERT_TRUE(g.desired.apply({Epoch{1}, {ins(1, {0, 0, -50})}}, 0.0).ok());
  ASSERT_TRUE(g.desired.apply({Epoch{2}, fresh}, 0.9).ok());
  cfg.age_escape_s = 1e9;
  Publisher q(cfg);
  ASSERT_TRUE(q.publish(g.desired, g.slots, ViewState{{0, 0, 0}, {0, 0, 1}}, 1.0).ok());
  EXPECT_FALSE(g.slots.contains(GaussianId{1}));
}

TEST(Publisher, AllowanceFollowsDisplaySlackWithinBounds) {
  PublisherConfig cfg{.mode = PublishMode::Progressive, .allowance_min = 100, .allowance_max = 1000, .allowance_initial = 400};
  cfg.display_period_s = 0.010;
  Publisher p(cfg);
  for (int i = 0; i < 200; ++i) p.report_frame_cost(0.002);  // lots of slack, but nothing to do
  EXPECT_EQ(p.allowance(), 400u);  // idle frames do not grow it
  // Saturated frames with slack grow it up to the bound.
  Fixture f(5000);
  std::vector<Edit> edits;
  for (std::uint64_t i = 0; i < 5000; ++i) edits.push_back(ins(i + 1, {0, 0, 1}));
  ASSERT_TRUE(f.desired.apply({Epoch{1}, edits}, 0.0).ok());
  for (int i = 0; i < 30 && f.desired.pending_count() > 0; ++i) {
    ASSERT_TRUE(p.publish(f.desired, f.slots, {}, 0.0).ok());
    p.report_frame_cost(0.002);
  }
  EXPECT_EQ(p.allowance(), 1000u);
  for (int i = 0; i < 200; ++i) p.report_frame_cost(0.0099);  // hardly any
  EXPECT_EQ(p.allowance(), 100u);
  p.report_frame_cost(std::numeric_limits<double>::quiet_NaN());  // ignored
  EXPECT_EQ(p.allowance(), 100u);
  Publisher bad(PublisherConfig{.allowance_min = 50, .allowance_max = 10, .allowance_initial = 5});
  EXPECT_EQ(bad.allowance(), 50u);  // bounds put in order
}

TEST(Publisher, FullReplacementNeverExceedsTheBudget) {
  const std::uint32_t cap = 300;
  Fixture f(cap);
  std::vector<Edit> first;
  for (std::uint64_t i = 0; i < cap; ++i) first.push_back(ins(i + 1, {0, 0, 1}));
  ASSERT_TRUE(f.desired.apply({Epoch{1}, first}, 0.0).ok());
  Publisher imm(PublisherConfig{.mode = PublishMode::Immediate});
  ASSERT_TRUE(imm.publish(f.desired, f.slots, {}, 0.0).ok());
  (void)f.slots.take_dirty_ranges();
  // A far teleport: every id leaves, as many new ones enter (removes first, as the codec orders them).
  std::vector<Edit> second;
  for (std::uint64_t i = 0; i < cap; ++i) second.push_back(Edit{EditKind::Remove, GaussianId{i + 1}, GaussianId{0}, {}});
  for (std::uint64_t i = 0; i < cap; ++i) second.push_back(ins(i + 1001, {0, 0, 1}));
  ASSERT_TRUE(f.desired.apply({Epoch{2}, second}, 0.0).ok());
  Publisher p(PublisherConfig{.mode = PublishMode::Progressive, .allowance_min = 7, .allowance_max = 7, .allowance_initial = 7});
  int frames = 0;
  while (f.desired.pending_count() > 0) {
    auto r = p.publish(f.desired, f.slots, ViewState{{0, 0, 0}, {0, 0, 1}}, 0.0);
    ASSERT_TRUE(r.ok()) << r.message();
    ASSERT_LE(f.slots.size(), cap);
    ASSERT_LE(r->slot_writes(), 7u);
    ASSERT_TRUE(f.slots.check().ok());
    // Inserts take over the slots of leaving Gaussians: no frame leaves holes.
    ASSERT_EQ(f.slots.size(), cap);
    ASSERT_LT(++frames, 1000);
  }
  for (std::uint64_t i = 0; i < cap; ++i) ASSERT_TRUE(f.slots.contains(GaussianId{i + 1001}));
  EXPECT_EQ(frames, (cap + 6) / 7);
}

// A far teleport replaces a full table: the leaving Gaussians are all out of view, so
// which of them gives up its slot first does not matter to the viewer, but it decides
// how many upload ranges a frame needs. They go in slot order: a frame's inserts land
// in consecutive slots. (Ordered by their support-driven priority instead, the slots
// were scattered: about one upload range per write.)
TEST(Publisher, InvisibleRemovesGiveUpTheirSlotsInSlotOrder) {
  constexpr std::uint32_t kCap = 4000;
  Fixture f(kCap);
  std::mt19937 rng(5);
  std::vector<Edit> first;
  for (std::uint64_t i = 0; i < kCap; ++i) {
    Edit e = ins(i + 1, {0, 0, -2});  // behind the viewer of the second frame
    e.value.support = rng() % 64;       // priorities differ, visibility does not
    first.push_back(e);
  }
  ASSERT_TRUE(f.desired.apply({Epoch{1}, first}, 0.0).ok());
  Publisher imm(PublisherConfig{.mode = PublishMode::Immediate});
  ASSERT_TRUE(imm.publish(f.desired, f.slots, {}, 0.0).ok());
  (void)f.slots.take_dirty_ranges();
  std::vector<Edit> swap;
  for (std::uint64_t i = 0; i < kCap; ++i) swap.push_back(Edit{EditKind::Remove, GaussianId{i + 1}, GaussianId{0}, {}});
  for (std::uint64_t i = 0; i < kCap; ++i) swap.push_back(ins(kCap + i + 1, {0, 0, 2}));
  ASSERT_TRUE(f.desired.apply({Epoch{2}, swap}, 1.0).ok());
  Publisher p(PublisherConfig{.mode = PublishMode::Progressive, .allowance_min = 500, .allowance_max = 500, .allowance_initial = 500});
  const ViewState view{{0, 0, 0}, {0, 0, 1}};
  for (int frame = 0; frame < 3; ++frame) {
    auto r = p.publish(f.desired, f.slots, view, 1.0);
    ASSERT_TRUE(r.ok()) << r.message();
    EXPECT_EQ(r->slot_writes(), 500u);
    const auto ranges = f.slots.take_dirty_ranges();
    EXPECT_LE(ranges.size(), 2u) << "frame " << frame;
    EXPECT_TRUE(f.slots.check().ok());
  }
  while (f.desired.pending_count() > 0) {
    auto r = p.publish(f.desired, f.slots, view, 1.0);
    ASSERT_TRUE(r.ok()) << r.message();
  }
  EXPECT_EQ(f.slots.size(), kCap);
  for (std::uint64_t i = 0; i < kCap; ++i) {
    EXPECT_EQ(f.slots.slot_of(GaussianId{i + 1}), kNoSlot);
    EXPECT_NE(f.slots.slot_of(GaussianId{kCap + i + 1}), kNoSlot);
  }
}

// The allowance is charged for the upload ranges a frame opens, not only for slot
// writes: scattered writes (each its own copy command) get fewer per frame than
// adjacent ones, so either kind of frame fits the same display budget.
TEST(Publisher, AllowanceChargesUploadRanges) {
  auto writes_in_one_frame = [](std::uint64_t stride) {
    Fixture f(1000);
    std::vector<Edit> edits;
    for (std::uint64_t i = 0; i < 1000; ++i) edits.push_back(ins(i + 1, {0, 0, 1}));
    EXPECT_TRUE(f.desired.apply({Epoch{1}, edits}, 0.0).ok());
    Publisher imm(PublisherConfig{.mode = PublishMode::Immediate});
    EXPECT_TRUE(imm.publish(f.desired, f.slots, {}, 0.0).ok());
    (void)f.slots.take_dirty_ranges();
    std::vector<Edit> updates;
    for (std::uint64_t i = 0; i < 1000; i += stride) {
      Edit u = ins(i + 1, {0, 0, 2});
      u.kind = EditKind::Update;
      updates.push_back(u);
    }
    EXPECT_TRUE(f.desired.apply({Epoch{2}, updates}, 1.0).ok());
    PublisherConfig cfg{.mode = PublishMode::Progressive, .allowance_min = 100, .allowance_max = 100, .allowance_initial = 100};
    cfg.range_cost = 9.0f;
    cfg.range_gap = 2;
    Publisher p(cfg);
    auto r = p.publish(f.desired, f.slots, ViewState{{0, 0, 0}, {0, 0, 1}}, 1.0);
    EXPECT_TRUE(r.ok());
    const auto ranges = f.slots.take_dirty_ranges(2);
    EXPECT_LE(r->slot_writes() + 9 * ranges.size(), 100u + 10u) << "stride " << stride;  // at most one write over
    EXPECT_GE(r->new_ranges, ranges.size());
    return r->slot_writes();
  };
  const std::uint32_t adjacent = writes_in_one_frame(1);
  const std::uint32_t scattered = writes_in_one_frame(10);
  // The estimate is conservative (a round's first write may look isolated until its
  // neighbours follow), so adjacent writes get most, not all, of the allowance.
  EXPECT_GE(adjacent, 60u);
  EXPECT_LE(scattered, 11u);
}

// A far teleport with the table full: every published Gaussian leaves and as many new
// ones arrive. With a backlog re-scored only a few entries per frame, the publisher still
// keeps the allowance and the capacity every frame, converges exactly, and publishes the
// new view's Gaussians first (they arrive after the teleport and are scored on arrival).
TEST(Publisher, TeleportBacklogKeepsTheBudgetAndServesTheNewViewFirst) {
  constexpr std::uint32_t kCap = 2000;
  Fixture f(kCap);
  std::vector<Edit> first;
  for (std::uint64_t i = 0; i < kCap; ++i) first.push_back(ins(i + 1, {static_cast<float>(i % 40) * 0.1f, 0, -5}));
  ASSERT_TRUE(f.desired.apply({Epoch{1}, first}, 0.0).ok());
  Publisher imm(PublisherConfig{.mode = PublishMode::Immediate});
  ASSERT_TRUE(imm.publish(f.desired, f.slots, {}, 0.0).ok());
  PublisherConfig cfg{.mode = PublishMode::Progressive, .allowance_min = 100, .allowance_max = 100, .allowance_initial = 100};
  cfg.rescore_per_frame = 16;
  cfg.age_escape_s = 1e9;
  Publisher p(cfg);
  const ViewState view{{0, 0, 0}, {0, 0, 1}};
  ASSERT_TRUE(p.publish(f.desired, f.slots, view, 0.0).ok());  // ranks the (empty) backlog
  std::vector<Edit> swap;
  for (std::uint64_t i = 0; i < kCap; ++i) swap.push_back(Edit{EditKind::Remove, GaussianId{i + 1}, GaussianId{0}, {}});
  // Half of the newcomers in view (ahead), half behind; interleaved so order alone cannot help.
  for (std::uint64_t i = 0; i < kCap; ++i)
    swap.push_back(ins(kCap + i + 1, {static_cast<float>(i % 40) * 0.1f, 0, (i % 2) ? -3.0f : 3.0f}));
  ASSERT_TRUE(f.desired.apply({Epoch{2}, swap}, 1.0).ok());
  std::size_t frames = 0, ahead_first = 0, behind_first = 0;
  double now = 1.0;
  while (f.desired.pending_count() > 0) {
    auto r = p.publish(f.desired, f.slots, view, now);
    ASSERT_TRUE(r.ok()) << r.message();
    ASSERT_LE(r->slot_writes(), 100u);
    ASSERT_LE(f.slots.size(), kCap);
    if (frames < 5)
      for (std::uint64_t i = 0; i < kCap; ++i)
        if (f.slots.contains(GaussianId{kCap + i + 1})) ++((i % 2) ? behind_first : ahead_first);
    now += 0.01;
    ASSERT_LT(++frames, 200u);
  }
  EXPECT_EQ(behind_first, 0u) << "the new view's Gaussians go first";
  EXPECT_GT(ahead_first, 0u);
  EXPECT_EQ(f.slots.size(), kCap);
  for (std::uint64_t i = 0; i < kCap; ++i) ASSERT_TRUE(f.slots.contains(GaussianId{kCap + i + 1}));
  EXPECT_TRUE(f.slots.check().ok());
  EXPECT_TRUE(f.desired.check().ok());
}
