// Identity tracking: a snapshot pair differing by 5 % perturbed, 2 % new and 2 % removed
// Gaussians under a random permutation keeps >= 99 % of the unchanged Gaussians' ids.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <unordered_map>

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include "gauss/engine/identity_tracker.h"
#include "gauss/engine/ply_gaussian.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/synthetic_scene.h"
#include "gauss/engine/trainer_snapshot.h"
#include "synthetic_test_scene.h"
#include "test_data.h"
#include "split_mix_rng.h"

namespace gauss {
namespace {

using Rng = test::SplitMixRng;

std::vector<Gaussian> synthetic_epoch(std::size_t n) {
  SyntheticSceneConfig c = test::small_synthetic_config(n, 6);
  c.converge_epochs = 2;
  auto scene = SyntheticScene::create(c);
  EXPECT_TRUE(scene.ok());
  SceneStore store;
  test::produce_all(*scene, store);
  return {store.gaussians().begin(), store.gaussians().end()};
}

std::function<GaussianId()> counter_from(std::uint64_t start) {
  auto next = std::make_shared<std::uint64_t>(start);
  return [next] { return GaussianId{(*next)++}; };
}

// The generator the identity test and benchmark score against: its fates are what it
// claims (fractions, truths, stripped ids) and it is a pure function of the seed.
TEST(TrainerSnapshot, FatesMatchTheConfigAndTheSeedDecides) {
  std::vector<Gaussian> previous(20000);
  for (std::size_t i = 0; i < previous.size(); ++i) {
    previous[i].id = GaussianId{i + 1};
    previous[i].position = {float(i % 100), float(i / 100), 0.0f};
  }
  const TrainerSnapshot a = make_trainer_snapshot(previous, {}, 7);
  std::size_t unchanged = 0, perturbed = 0, fresh = 0;
  for (std::size_t i = 0; i < a.gaussians.size(); ++i) {
    EXPECT_EQ(a.gaussians[i].id, GaussianId{0});
    switch (a.fate[i]) {
      case SnapshotFate::Unchanged:
        ++unchanged;
        EXPECT_EQ(a.gaussians[i].position, previous[to_underlying(a.truth[i]) - 1].position);
        break;
      case SnapshotFate::Perturbed: ++perturbed; break;
      case SnapshotFate::New: ++fresh; EXPECT_EQ(a.truth[i], GaussianId{0}); break;
    }
  }
  EXPECT_EQ(a.removed + unchanged + perturbed, previous.size());
  EXPECT_EQ(fresh, previous.size() / 50);
  EXPECT_NEAR(double(a.removed) / 20000.0, 0.02, 0.005);
  EXPECT_NEAR(double(perturbed) / 20000.0, 0.05, 0.008);
  const TrainerSnapshot b = make_trainer_snapshot(previous, {}, 7);
  const TrainerSnapshot c = make_trainer_snapshot(previous, {}, 8);
  ASSERT_EQ(a.gaussians.size(), b.gaussians.size());
  EXPECT_TRUE(std::equal(a.truth.begin(), a.truth.end(), b.truth.begin()));
  EXPECT_FALSE(c.truth.size() == a.truth.size() && std::equal(a.truth.begin(), a.truth.end(), c.truth.begin()));
}

TEST(IdentityTracker, KeepsIdsOfUnchangedAndSlightlyChangedGaussiansUnderPermutation) {
  const std::vector<Gaussian> previous = synthetic_epoch(60000);
  std::uint64_t max_id = 0;
  for (const Gaussian& g : previous) max_id = std::max(max_id, to_underlying(g.id));
  for (std::uint64_t seed : {1u, 2u, 3u, 4u}) {
    const float drift = seed == 4 ? 0.1f : 0.0f;
    TrainerSnapshot pair = make_trainer_snapshot(previous, {.drift_sigmas = drift}, seed);
    auto r = track_identity(previous, pair.gaussians, {}, counter_from(max_id + 1));
    ASSERT_TRUE(r.ok()) << r.message();
    std::size_t unchanged = 0, unchanged_kept = 0, perturbed = 0, perturbed_kept = 0, fresh_new = 0, n_new = 0;
    for (std::size_t i = 0; i < pair.gaussians.size(); ++i) {
      const bool kept = pair.gaussians[i].id == pair.truth[i];
      switch (pair.fate[i]) {
        case SnapshotFate::Unchanged: ++unchanged; unchanged_kept += kept; break;
        case SnapshotFate::Perturbed: ++perturbed; perturbed_kept += kept; break;
        case SnapshotFate::New: ++n_new; fresh_new += to_underlying(pair.gaussians[i].id) > max_id; break;
      }
    }
    std::printf("seed %llu drift %.1f sigma: previous %zu snapshot %zu | kept %zu (exact %zu) fresh %zu removed %zu | "
                "unchanged kept %zu/%zu, perturbed kept %zu/%zu, new given fresh ids %zu/%zu (truth: %zu removed)\n",
                static_cast<unsigned long long>(seed), double(drift), r->previous, r->current, r->kept, r->exact, r->fresh,
                r->removed, unchanged_kept, unchanged, perturbed_kept, perturbed, fresh_new, n_new, pair.removed);
    EXPECT_GE(double(unchanged_kept), 0.99 * double(unchanged));
    EXPECT_GE(double(perturbed_kept), 0.95 * double(perturbed));
    EXPECT_GE(double(fresh_new), 0.9 * double(n_new));
    EXPECT_EQ(r->kept + r->fresh, pair.gaussians.size());
    EXPECT_EQ(r->kept + r->removed, previous.size());
    // One-to-one: no id handed out twice.
    std::vector<std::uint64_t> ids;
    for (const Gaussian& g : pair.gaussians) ids.push_back(to_underlying(g.id));
    std::sort(ids.begin(), ids.end());
    EXPECT_EQ(std::adjacent_find(ids.begin(), ids.end()), ids.end());
  }
}

TEST(IdentityTracker, DeterministicAndCarriersMatchOnlyCarriers) {
  std::vector<Gaussian> prev(2);
  prev[0].id = GaussianId{10};
  prev[0].carrier = true;
  prev[1].id = GaussianId{11};
  prev[1].position = glm::vec3(5.0f);
  std::vector<Gaussian> cur(2);
  cur[0].position = glm::vec3(0.01f);  // near the carrier, but it is an appearance Gaussian
  cur[1] = prev[1];
  auto r = track_identity(prev, cur, {}, counter_from(100));
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(cur[0].id, GaussianId{100});
  EXPECT_EQ(cur[1].id, GaussianId{11});
  EXPECT_EQ(r->removed, 1u);
  // Same input, same answer.
  std::vector<Gaussian> cur2 = cur;
  auto r2 = track_identity(prev, cur2, {}, counter_from(100));
  ASSERT_TRUE(r2.ok());
  for (std::size_t i = 0; i < cur.size(); ++i) EXPECT_EQ(cur[i].id, cur2[i].id);
}

TEST(IdentityTracker, EmptySidesAndBadInput) {
  std::vector<Gaussian> some(3);
  for (std::size_t i = 0; i < 3; ++i) some[i].position = glm::vec3(float(i));
  auto a = track_identity({}, some, {}, counter_from(1));
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(a->fresh, 3u);
  auto b = track_identity(some, std::span<Gaussian>{}, {}, counter_from(1));
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(b->removed, 3u);

  std::vector<Gaussian> bad = some;
  bad[1].opacity_logit = std::numeric_limits<float>::quiet_NaN();
  for (Gaussian& g : bad) g.id = GaussianId{77};
  auto c = track_identity(some, bad, {}, counter_from(1));
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.message().find("snapshot Gaussian 1"), std::string::npos) << c.message();
  EXPECT_NE(c.message().find("opacity"), std::string::npos) << c.message();
  for (const Gaussian& g : bad) EXPECT_EQ(g.id, GaussianId{77}) << "ids changed on failure";
  IdentityTrackerConfig cfg;
  cfg.max_distance_sigmas = -1.0f;
  EXPECT_FALSE(track_identity(some, some, cfg, counter_from(1)).ok());
}

// The rule of identity_tracker.h written the plain way, every pair compared: the exact pass
// (the first unused bit-identical record, by index), then for the rest every candidate within
// its radius and the limits, the kCandidates cheapest per snapshot Gaussian (ties by previous
// index) pooled and taken greedily by (cost, snapshot index, previous index), then fresh ids
// in snapshot order. The same float expressions, so the same bits.
std::vector<GaussianId> reference_ids(std::span<const Gaussian> previous, std::span<const Gaussian> current,
                                      const IdentityTrackerConfig& c, std::uint64_t fresh_from) {
  constexpr std::uint32_t kNone = 0xFFFFFFFFu;
  std::vector<std::uint32_t> match(current.size(), kNone);
  std::vector<char> taken(previous.size(), 0);
  auto same = [](const Gaussian& a, const Gaussian& b) {
    return a.carrier == b.carrier && a.position == b.position && a.log_scale == b.log_scale && a.sh_dc == b.sh_dc &&
           a.rotation == b.rotation && a.opacity_logit == b.opacity_logit;
  };
  for (std::size_t i = 0; i < current.size(); ++i)
    for (std::size_t j = 0; j < previous.size(); ++j)
      if (!taken[j] && same(previous[j], current[i])) {
        taken[j] = 1;
        match[i] = std::uint32_t(j);
        break;
      }
  auto sigma_of = [](const Gaussian& q) {
    return std::exp(std::max(q.log_scale.x, std::max(q.log_scale.y, q.log_scale.z)));
  };
  std::vector<float> sigmas;
  for (std::size_t j = 0; j < previous.size(); ++j)
    if (!taken[j]) sigmas.push_back(sigma_of(previous[j]));
  struct Pair {
    float cost;
    std::uint32_t cur, prev;
  };
  std::vector<Pair> pairs;
  if (!sigmas.empty()) {
    float cell = c.cell_size;
    if (cell <= 0.0f) {
      auto p90 = sigmas.begin() + std::ptrdiff_t(sigmas.size() * 9 / 10);
      std::nth_element(sigmas.begin(), p90, sigmas.end());
      cell = 2.0f * c.max_distance_sigmas * *p90;
    }
    cell = std::max(cell, 1e-6f);
    auto max_abs3 = [](const glm::vec3& v) { return std::max(std::abs(v.x), std::max(std::abs(v.y), std::abs(v.z))); };
    for (std::size_t i = 0; i < current.size(); ++i) {
      if (match[i] != kNone) continue;
      const Gaussian& g = current[i];
      std::vector<Pair> all;
      for (std::size_t j = 0; j < previous.size(); ++j) {
        const Gaussian& q = previous[j];
        if (taken[j] || q.carrier != g.carrier) continue;
        const float radius = std::min(c.max_distance_sigmas * sigma_of(q), 0.5f * cell);
        const glm::vec3 d = g.position - q.position;
        const float dist2 = d.x * d.x + d.y * d.y + d.z * d.z;
        if (dist2 > radius * radius) continue;
        const float ds = max_abs3(g.log_scale - q.log_scale) / c.max_log_scale_change;
        const float dc = max_abs3(g.sh_dc - q.sh_dc) / c.max_sh_dc_change;
        const float dop = std::abs(g.opacity_logit - q.opacity_logit) / c.max_opacity_logit_change;
        if (ds > 1.0f || dc > 1.0f || dop > 1.0f) continue;
        all.push_back({dist2 / (radius * radius) + ds * ds + dc * dc + dop * dop, std::uint32_t(i), std::uint32_t(j)});
      }
      std::sort(all.begin(), all.end(), [](const Pair& x, const Pair& y) { return x.cost != y.cost ? x.cost < y.cost : x.prev < y.prev; });
      all.resize(std::min<std::size_t>(all.size(), 4));
      pairs.insert(pairs.end(), all.begin(), all.end());
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& x, const Pair& y) {
    if (x.cost != y.cost) return x.cost < y.cost;
    if (x.cur != y.cur) return x.cur < y.cur;
    return x.prev < y.prev;
  });
  for (const Pair& p : pairs)
    if (match[p.cur] == kNone && !taken[p.prev]) {
      match[p.cur] = p.prev;
      taken[p.prev] = 1;
    }
  std::vector<GaussianId> ids;
  for (std::size_t i = 0; i < current.size(); ++i)
    ids.push_back(match[i] != kNone ? previous[match[i]].id : GaussianId{fresh_from++});
  return ids;
}

// The tracker's grid and indexes are a faster way to the same answer: on crowded scenes (many
// candidates per Gaussian, sizes spread over two decades and clamped, coincident duplicates,
// carriers, moved, recoloured, resized and new Gaussians, reordered) it gives exactly the ids
// the plain rule gives, with the automatic cell and a given one.
TEST(IdentityTracker, GivesWhatThePlainRuleGives) {
  Rng rng{23};
  for (int round = 0; round < 3; ++round) {
    std::vector<Gaussian> previous;
    for (std::size_t j = 0; j < 2500; ++j) {
      Gaussian g;
      g.id = GaussianId{j + 1};
      g.position = {rng.uniform(0.0f, 1.0f), rng.uniform(0.0f, 0.5f), rng.uniform(0.0f, 1.0f)};
      g.log_scale = {rng.uniform(-6.0f, -1.5f), rng.uniform(-6.0f, -2.0f), rng.uniform(-8.0f, -4.0f)};
      g.rotation = glm::normalize(glm::vec4(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)));
      g.opacity_logit = rng.uniform(-3.0f, 4.0f);
      g.sh_dc = {rng.uniform(-0.3f, 0.3f), rng.uniform(-0.3f, 0.3f), rng.uniform(-0.3f, 0.3f)};
      g.carrier = rng.next() % 20 == 0;
      previous.push_back(g);
    }
    for (std::size_t j = 0; j < 40; ++j) {  // bit-identical duplicates
      previous.push_back(previous[std::size_t(rng.next() % 2500)]);
      previous.back().id = GaussianId{10000 + j};
    }
    std::vector<Gaussian> current;
    for (const Gaussian& q : previous) {
      const std::uint64_t roll = rng.next() % 10;
      if (roll == 0) continue;  // removed
      Gaussian g = q;
      g.id = GaussianId{0};
      if (roll < 5) g.position += glm::vec3(rng.uniform(-0.02f, 0.02f), rng.uniform(-0.02f, 0.02f), rng.uniform(-0.02f, 0.02f));
      if (roll == 5) g.sh_dc.x += rng.uniform(-0.6f, 0.6f);
      if (roll == 6) g.log_scale += glm::vec3(rng.uniform(-0.6f, 0.6f));
      current.push_back(g);
    }
    for (std::size_t k = 0; k < 200; ++k) {  // new
      Gaussian g = previous[std::size_t(rng.next() % previous.size())];
      g.position += glm::vec3(rng.uniform(-0.05f, 0.05f));
      g.opacity_logit = rng.uniform(-3.0f, 4.0f);
      current.push_back(g);
    }
    for (std::size_t i = current.size(); i > 1; --i) std::swap(current[i - 1], current[std::size_t(rng.next() % i)]);
    for (float cell : {0.0f, 0.05f}) {
      IdentityTrackerConfig config;
      config.cell_size = cell;
      std::vector<Gaussian> tracked = current;
      auto r = track_identity(previous, tracked, config, counter_from(1'000'000));
      ASSERT_TRUE(r.ok()) << r.message();
      const std::vector<GaussianId> expected = reference_ids(previous, current, config, 1'000'000);
      std::size_t differ = 0;
      for (std::size_t i = 0; i < tracked.size(); ++i) differ += tracked[i].id != expected[i];
      EXPECT_EQ(differ, 0u) << "round " << round << " cell " << cell << ": " << r->kept << " kept (" << r->exact
                            << " exact), " << r->fresh << " fresh";
      EXPECT_GT(r->exact, 600u);
      EXPECT_GT(r->kept - r->exact, 500u);
    }
  }
}

TEST(IdentityTracker, RealSceneReorderedKeepsEveryId) {
  GAUSS_REQUIRE_DATA(path, "splats/fruit_drops_sh3.ply");
  auto scene = read_gaussian_ply(path);
  ASSERT_TRUE(scene.ok()) << scene.message();
  std::vector<Gaussian> prev = scene->cloud.gaussians;
  for (std::size_t i = 0; i < prev.size(); ++i) prev[i].id = GaussianId{i + 1};
  std::vector<Gaussian> cur = prev;
  Rng rng{9};
  for (std::size_t i = cur.size(); i > 1; --i) std::swap(cur[i - 1], cur[std::size_t(rng.next() % i)]);
  std::vector<GaussianId> truth;
  for (Gaussian& g : cur) {
    truth.push_back(g.id);
    g.id = GaussianId{0};
  }
  auto r = track_identity(prev, cur, {}, counter_from(1'000'000));
  ASSERT_TRUE(r.ok()) << r.message();
  EXPECT_EQ(r->kept, prev.size());
  for (std::size_t i = 0; i < cur.size(); ++i) ASSERT_EQ(cur[i].id, truth[i]) << i;
}

}  // namespace
}  // namespace gauss
