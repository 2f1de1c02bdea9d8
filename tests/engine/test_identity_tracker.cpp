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
