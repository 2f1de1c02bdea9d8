// Publisher under random host traffic: whatever the host sends within the budget (removes
// before inserts, as its differ orders them), in whatever bursts, between frames of any
// cost, with the mode switched now and then, publication never fails, never exceeds the
// slot table, and ends with the published set equal to the desired one. (A far teleport
// at M = 200k once stopped a client with "slot table full and no pending remove to make
// room". A stall that piles up batches found more: arrivals ranked after a newer view of
// their entry (a rescan after the lists overflowed, or a publication) revived states the
// entries had left, and an insert so shadowed was never published: the client never
// settled.)
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <random>
#include <unordered_set>
#include <vector>

#include <glm/geometric.hpp>

#include "gauss/engine/publisher.h"

using namespace gauss;

namespace {

struct PublisherWorld {
  std::uint32_t capacity;
  std::vector<glm::vec3> position;  // per id - 1: where each id of the universe lies
  std::unordered_set<std::uint64_t> desired;  // the host's view of the client's desired set
  std::uint32_t version{0};
};

Edit insert_of(const PublisherWorld& w, std::uint64_t id, std::uint32_t version) {
  Edit e{EditKind::Insert, GaussianId{id}, GaussianId{0}, {}};
  e.value.id = GaussianId{id};
  e.value.position = w.position[id - 1];
  e.value.opacity_logit = 0.5f + 0.001f * static_cast<float>(version % 100);
  e.value.support = static_cast<std::uint32_t>(id % 64);
  return e;
}

// One host batch: some desired ids leave, some updates, then newcomers up to the budget.
// `teleport` swaps (nearly) the whole set.
std::vector<Edit> host_batch(PublisherWorld& w, std::mt19937& rng, bool teleport) {
  std::vector<std::uint64_t> in(w.desired.begin(), w.desired.end());
  std::sort(in.begin(), in.end());
  std::shuffle(in.begin(), in.end(), rng);
  const std::size_t leave = teleport ? in.size() : std::uniform_int_distribution<std::size_t>(0, in.size() / 4)(rng);
  std::vector<Edit> removes, updates, inserts;
  for (std::size_t k = 0; k < leave; ++k) {
    removes.push_back(Edit{EditKind::Remove, GaussianId{in[k]}, GaussianId{0}, {}});
    w.desired.erase(in[k]);
  }
  ++w.version;
  const std::size_t update = std::uniform_int_distribution<std::size_t>(0, (in.size() - leave) / 8)(rng);
  for (std::size_t k = leave; k < leave + update && k < in.size(); ++k) {
    Edit e = insert_of(w, in[k], w.version);
    e.kind = EditKind::Update;
    updates.push_back(e);
  }
  const std::size_t room = w.capacity - w.desired.size();
  const std::size_t enter = teleport ? room : std::uniform_int_distribution<std::size_t>(0, room)(rng);
  std::uniform_int_distribution<std::uint64_t> any(1, w.position.size());
  for (std::size_t tries = 0; inserts.size() < enter && tries < 20 * enter + 100; ++tries) {
    const std::uint64_t id = any(rng);  // ids that left may come back
    if (w.desired.count(id)) continue;
    bool left_now = false;
    for (std::size_t k = 0; k < leave && !left_now; ++k) left_now = in[k] == id;
    if (left_now) continue;  // a remove and an insert of one id in one batch: not what the differ sends
    w.desired.insert(id);
    inserts.push_back(insert_of(w, id, w.version));
  }
  // The differ pairs leavers with enterers as one Replace edit where it can.
  std::size_t pairs = std::uniform_int_distribution<std::size_t>(0, std::min(removes.size(), inserts.size()))(rng);
  std::vector<Edit> replaces;
  for (std::size_t k = 0; k < pairs; ++k) {
    Edit e = inserts.back();
    inserts.pop_back();
    e.kind = EditKind::Replace;
    e.leaving = removes.back().id;
    removes.pop_back();
    replaces.push_back(e);
  }
  std::vector<Edit> all;
  all.insert(all.end(), removes.begin(), removes.end());
  all.insert(all.end(), replaces.begin(), replaces.end());
  all.insert(all.end(), updates.begin(), updates.end());
  all.insert(all.end(), inserts.begin(), inserts.end());
  return all;
}

void run_seed(std::uint32_t seed) {
  std::mt19937 rng(seed);
  PublisherWorld w;
  w.capacity = std::uniform_int_distribution<std::uint32_t>(50, 600)(rng);
  const std::uint32_t universe = w.capacity * std::uniform_int_distribution<std::uint32_t>(2, 4)(rng);
  std::uniform_real_distribution<float> coord(-10.0f, 10.0f);
  for (std::uint32_t i = 0; i < universe; ++i) w.position.push_back({coord(rng), coord(rng) * 0.2f, coord(rng)});
  DesiredState desired(w.capacity);
  SlotTable slots = SlotTable::create(w.capacity).value();
  PublisherConfig cfg;
  cfg.mode = PublishMode::Progressive;
  cfg.allowance_min = std::uniform_int_distribution<std::uint32_t>(1, 20)(rng);
  cfg.allowance_max = cfg.allowance_min + std::uniform_int_distribution<std::uint32_t>(0, 200)(rng);
  cfg.allowance_initial = cfg.allowance_min;
  cfg.display_period_s = 0.01;
  cfg.age_escape_s = std::uniform_real_distribution<double>(0.02, 0.5)(rng);
  cfg.escape_quota = std::uniform_int_distribution<std::uint32_t>(0, 30)(rng);
  cfg.rescore_per_frame = std::uniform_int_distribution<std::uint32_t>(1, 64)(rng);
  cfg.rank_allowances = std::uniform_int_distribution<std::uint32_t>(0, 3)(rng);
  Publisher p(cfg);
  double now = 0.0;
  Epoch epoch{0};
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  ViewState view{{0, 1, 0}, {0, 0, 1}};
  for (int frame = 0; frame < 400; ++frame) {
    // 0..2 batches before this frame; now and then a teleport.
    // Now and then a stall: batches pile up until the arrival lists overflow.
    const int batches = std::uniform_int_distribution<int>(0, 19)(rng) == 0 ? 30 : std::uniform_int_distribution<int>(0, 2)(rng);
    for (int b = 0; b < batches; ++b) {
      const bool teleport = std::uniform_int_distribution<int>(0, 9)(rng) == 0;
      epoch = Epoch{to_underlying(epoch) + 1};
      std::vector<Edit> edits = host_batch(w, rng, teleport);
      const bool resync = std::uniform_int_distribution<int>(0, 14)(rng) == 0;
      if (resync) {  // the whole set as a snapshot (after a reconnect or a lost batch)
        edits.clear();
        for (std::uint64_t id : w.desired) edits.push_back(insert_of(w, id, w.version + (id % 3 == 0)));
        std::shuffle(edits.begin(), edits.end(), rng);
      }
      auto rep = resync ? desired.apply_resync({epoch, edits}, now) : desired.apply({epoch, edits}, now);
      ASSERT_TRUE(rep.ok()) << "seed " << seed << ": " << rep.message();
      ASSERT_EQ(rep->rejected, 0u) << "seed " << seed << " frame " << frame;
      if (teleport) {
        view.eye = {unit(rng) * 8, 1, unit(rng) * 8};
        view.forward = glm::normalize(glm::vec3(unit(rng), 0.1f, unit(rng)));
      }
    }
    if (std::uniform_int_distribution<int>(0, 3)(rng) == 0)
      view.eye += glm::vec3(unit(rng), 0, unit(rng)) * 0.1f;
    if (std::uniform_int_distribution<int>(0, 29)(rng) == 0)  // the viewer's panel switches modes
      p.set_mode(p.config().mode == PublishMode::Immediate ? PublishMode::Progressive : PublishMode::Immediate);
    auto r = p.publish(desired, slots, view, now);
    ASSERT_TRUE(r.ok()) << "seed " << seed << " frame " << frame << ": " << r.message();
    ASSERT_LE(slots.size(), w.capacity);
    p.report_frame_cost(std::uniform_real_distribution<double>(0.002, 0.02)(rng));
    (void)slots.take_dirty_ranges();
    now += 0.0125;
  }
  // Quiet: everything the host wants gets published.
  for (int frame = 0; desired.pending_count() > 0; ++frame) {
    auto r = p.publish(desired, slots, view, now);
    ASSERT_TRUE(r.ok()) << "seed " << seed << " drain: " << r.message();
    p.report_frame_cost(0.002);
    now += 0.0125;
    ASSERT_LT(frame, 100000) << "seed " << seed << ": publication does not finish";
  }
  ASSERT_EQ(slots.size(), w.desired.size()) << "seed " << seed;
  for (std::uint64_t id : w.desired) ASSERT_TRUE(slots.contains(GaussianId{id})) << "seed " << seed;
  ASSERT_TRUE(slots.check().ok());
  ASSERT_TRUE(desired.check().ok());
}

}  // namespace

TEST(PublisherRandom, HostTrafficWithinTheBudgetAlwaysPublishes) {
  // Seeds 1..60; GAUSS_PUBLISHER_SEEDS=N runs 1..N (the sanitizer pass of scripts/test runs
  // fewer: 20 of them took 16 s there, all 60 took 52 s).
  std::uint32_t seeds = 60;
  if (const char* env = std::getenv("GAUSS_PUBLISHER_SEEDS"); env && *env)
    seeds = std::uint32_t(std::strtoul(env, nullptr, 10));
  for (std::uint32_t seed = 1; seed <= seeds; ++seed) {
    run_seed(seed);
    if (HasFatalFailure()) return;
  }
}
