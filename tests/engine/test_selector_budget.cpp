// Selector: exact semantic reservation (M_obj = min(|G_obj|, floor(rho M))), |R*| <= M,
// request validation, determinism with ties by id, carriers / ineligible excluded, view
// preference, the pose-independent global layer and hysteresis under small head motion.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <set>
#include <thread>

#include <gtest/gtest.h>

#include <glm/gtc/quaternion.hpp>

#include "gauss/engine/eligibility.h"
#include "gauss/engine/labels_io.h"
#include "gauss/engine/ply_gaussian.h"
#include "gauss/engine/selector.h"
#include "select_test_scene.h"
#include "test_data.h"

namespace gauss {
namespace {

std::size_t count_in_objects(const SceneStore& store, const Selection& sel, const std::vector<ObjectId>& objs) {
  std::size_t n = 0;
  for (std::uint32_t i : sel.indices) {
    const ObjectId o = store.gaussians()[i].object;
    n += std::find(objs.begin(), objs.end(), o) != objs.end() ? 1 : 0;
  }
  return n;
}

TEST(SelectorBudget, ObjectShareIsExactAndTotalNeverExceedsM) {
  SceneStore store;
  test::fill_test_scene(store, 20000, 1);
  std::mt19937_64 rng(2);
  Selector selector;
  const SemanticQuery queries[] = {SemanticQuery::for_class("chair"), SemanticQuery::for_class("TABLE"),
                                   SemanticQuery::for_instance(ObjectId{4}), SemanticQuery::for_instance(ObjectId{6})};
  const std::size_t budgets[] = {1, 777, 5000, 19000, 40000};
  const double rhos[] = {0.0, 0.1, 0.37, 0.9, 1.0};
  int cases = 0;
  for (const SemanticQuery& q : queries) {
    for (std::size_t m : budgets) {
      for (double rho : rhos) {
        SelectionRequest req;
        req.budget = m;
        req.client_capacity = 40000;
        req.query = q;
        req.rho = rho;
        auto sel = selector.select(store, test::random_test_pose(rng), req);
        ASSERT_TRUE(sel.ok()) << sel.message();
        const auto objs = sel->query->ids();
        const std::size_t g_obj = sel->object_candidates;
        const std::size_t m_obj = std::min(g_obj, static_cast<std::size_t>(std::floor(rho * static_cast<double>(m))));
        EXPECT_EQ(sel->object_budget, m_obj);
        EXPECT_EQ(count_in_objects(store, *sel, objs), m_obj) << q.describe() << " M=" << m << " rho=" << rho;
        EXPECT_LE(sel->ids.size(), m);
        EXPECT_EQ(sel->ids.size(), std::min(m, m_obj + sel->background_candidates));
        EXPECT_TRUE(std::is_sorted(sel->ids.begin(), sel->ids.end()));
        EXPECT_EQ(std::adjacent_find(sel->ids.begin(), sel->ids.end()), sel->ids.end());
        ++cases;
      }
    }
  }
  EXPECT_EQ(cases, 100);
}

// Without the background's leaves (a LoD cut stands in for them): the reservation is the
// full selection's own, leaf for leaf, whatever the query, M and rho; nothing of the
// background, the global layer's picks included; the counts the caller decides with are the
// same. Two selectors walk the same poses, so their hysteresis differs only in what one of
// them never selected.
TEST(SelectorBudget, WithoutBackgroundLeavesTheReservationIsTheFullSelections) {
  SceneStore store;
  test::fill_test_scene(store, 20000, 1);
  std::mt19937_64 rng(5);
  const SemanticQuery queries[] = {SemanticQuery::for_class("chair"), SemanticQuery::for_instance(ObjectId{6})};
  int cases = 0;
  for (const SemanticQuery& q : queries) {
    for (double rho : {0.0, 0.37, 1.0}) {
      Selector full, reservation_only;
      for (std::size_t m : {std::size_t{1}, std::size_t{777}, std::size_t{5000}, std::size_t{19000}}) {
        SelectionRequest req;
        req.budget = m;
        req.client_capacity = 40000;
        req.query = q;
        req.rho = rho;
        const ClientPose pose = test::random_test_pose(rng);
        auto a = full.select(store, pose, req);
        req.background_leaves = false;
        auto b = reservation_only.select(store, pose, req);
        ASSERT_TRUE(a.ok() && b.ok());
        const auto objs = a->query->ids();
        std::vector<GaussianId> object_part;
        for (std::size_t k = 0; k < a->ids.size(); ++k)
          if (std::find(objs.begin(), objs.end(), store.gaussians()[a->indices[k]].object) != objs.end())
            object_part.push_back(a->ids[k]);
        EXPECT_EQ(b->ids, object_part) << q.describe() << " M=" << m << " rho=" << rho;
        EXPECT_EQ(b->ids.size(), b->indices.size());
        EXPECT_EQ(b->object_selected, a->object_selected);
        EXPECT_EQ(b->background_selected, 0u);
        EXPECT_EQ(b->background_candidates, a->background_candidates);
        EXPECT_EQ(b->object_candidates, a->object_candidates);
        ++cases;
      }
    }
  }
  EXPECT_EQ(cases, 24);
  // No query: nothing selected, the background counted.
  Selector s;
  SelectionRequest req;
  req.budget = 5000;
  req.client_capacity = 40000;
  req.background_leaves = false;
  auto none = s.select(store, test::random_test_pose(rng), req);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->ids.empty());
  EXPECT_GT(none->background_candidates, 5000u);
}

// A request without the background's leaves leaves the background's global layer unmade
// (a LoD cut stands in for those leaves); a request with them on the same partition then
// makes it: the same selection as a selector asked with them alone (the LoD selector does
// this where the background fits the budget).
TEST(SelectorBudget, TheBackgroundLayerIsMadeWhenTheBackgroundIsFirstAskedFor) {
  SceneStore store;
  test::fill_test_scene(store, 20000, 3);
  std::mt19937_64 rng(11);
  int cases = 0;
  for (const bool query : {false, true}) {
    Selector later;  // across budgets: each new partition drops the layer made for the last
    for (std::size_t m : {std::size_t{777}, std::size_t{5000}, std::size_t{19000}}) {
      SelectionRequest req;
      req.budget = m;
      req.client_capacity = 40000;
      if (query) {
        req.query = SemanticQuery::for_class("chair");
        req.rho = 0.5;
      }
      const ClientPose pose = test::random_test_pose(rng);
      Selector alone;
      req.background_leaves = false;
      auto reservation = later.select(store, pose, req);
      ASSERT_TRUE(reservation.ok());
      // The same resident set for both, so hysteresis treats them alike.
      later.set_resident(reservation->ids);
      alone.set_resident(reservation->ids);
      req.background_leaves = true;
      auto a = later.select(store, pose, req);
      auto b = alone.select(store, pose, req);
      ASSERT_TRUE(a.ok() && b.ok());
      EXPECT_GT(a->background_selected, 0u);
      EXPECT_EQ(a->ids, b->ids) << "query " << query << " M=" << m;
      EXPECT_EQ(a->global_selected, b->global_selected);
      EXPECT_EQ(a->background_selected, b->background_selected);
      // And back: the reservation alone again, as before.
      req.background_leaves = false;
      later.set_resident(reservation->ids);
      auto again = later.select(store, pose, req);
      ASSERT_TRUE(again.ok());
      EXPECT_EQ(again->ids, reservation->ids);
      ++cases;
    }
  }
  EXPECT_EQ(cases, 6);
}

// The view scores are taken eight at a time with AVX2 where the CPU has it, four at a time
// with SSE2 otherwise (GAUSS_SIMD=sse2 forces that): the same keys lane for lane, so the same
// selections, with hysteresis carried along a walk, with and without a query, for a scene
// whose size is no multiple of 8.
TEST(SelectorBudget, TheAvx2AndSse2ScoresSelectTheSameLeaves) {
#if defined(__x86_64__)
  if (!__builtin_cpu_supports("avx2")) GTEST_SKIP() << "this CPU has no AVX2: both runs would take SSE2";
#endif
  SceneStore store;
  test::fill_test_scene(store, 20003, 9);
  auto walk = [&](bool sse2) {
    if (sse2)
      setenv("GAUSS_SIMD", "sse2", 1);
    else
      unsetenv("GAUSS_SIMD");
    std::mt19937_64 rng(17);
    std::vector<std::vector<GaussianId>> sets;
    Selector selector;
    for (int step = 0; step < 12; ++step) {
      SelectionRequest req;
      req.budget = 4001;
      req.client_capacity = 40000;
      if (step >= 6) {
        req.query = SemanticQuery::for_class("chair");
        req.rho = 0.6;
        req.background_leaves = step % 2 == 0;
      }
      auto s = selector.select(store, test::random_test_pose(rng), req);
      EXPECT_TRUE(s.ok());
      sets.push_back(s.ok() ? s->ids : std::vector<GaussianId>{});
    }
    unsetenv("GAUSS_SIMD");
    return sets;
  };
  const auto wide = walk(false);
  const auto narrow = walk(true);
  ASSERT_EQ(wide.size(), narrow.size());
  for (std::size_t k = 0; k < wide.size(); ++k) {
    EXPECT_FALSE(wide[k].empty());
    EXPECT_EQ(wide[k], narrow[k]) << "step " << k;
  }
  // Equal Gaussians on a sphere around the head: their utilities differ by rounding alone, so
  // the top half of them is decided by the last bits of the keys (a key one ulp off moves it).
  SceneStore ring;
  ASSERT_TRUE(ring.begin_next_epoch().ok());
  for (int i = 0; i < 5003; ++i) {
    Gaussian g;
    g.id = ring.allocate_id();
    const double a = 0.0021 * i, b = 0.37 * std::sin(0.013 * i);
    g.position = glm::vec3(float(2.0 * std::cos(b) * std::sin(a)), float(2.0 * std::sin(b)), float(-2.0 * std::cos(b) * std::cos(a)));
    g.log_scale = glm::vec3(-4.0f);
    ASSERT_TRUE(ring.insert(g).ok());
  }
  ASSERT_TRUE(ring.commit_epoch().ok());
  ClientPose head;
  head.tan_half_fov_x = head.tan_half_fov_y = 1.0;
  SelectionRequest req;
  req.budget = 600;  // about half of those in view, where the facing factor is 1
  req.client_capacity = 5003;
  std::vector<GaussianId> first;
  for (const bool sse2 : {false, true}) {
    if (sse2) setenv("GAUSS_SIMD", "sse2", 1);
    Selector selector;
    auto s = selector.select(ring, head, req);
    unsetenv("GAUSS_SIMD");
    ASSERT_TRUE(s.ok());
    if (!sse2) first = s->ids;
    else EXPECT_EQ(s->ids, first) << "the rounding-decided ring";
  }
}

TEST(SelectorBudget, BadRequestsAreClearErrors) {
  SceneStore store;
  test::fill_test_scene(store, 500, 3);
  Selector selector;
  const ClientPose pose;
  SelectionRequest req;
  req.budget = 0;
  auto r = selector.select(store, pose, req);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("budget"), std::string::npos);
  req.budget = 500;
  req.client_capacity = 499;
  r = selector.select(store, pose, req);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("capacity"), std::string::npos);
  req.client_capacity = 1000;
  for (double rho : {-0.01, 1.01, std::numeric_limits<double>::quiet_NaN()}) {
    req.rho = rho;
    r = selector.select(store, pose, req);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.message().find("rho"), std::string::npos);
  }
  req.rho = 0.5;
  req.query = SemanticQuery::for_class("giraffe");
  r = selector.select(store, pose, req);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("unknown class"), std::string::npos);
  req.query = SemanticQuery::for_instance(ObjectId{99});
  EXPECT_FALSE(selector.select(store, pose, req).ok());
  req.query.reset();
  ClientPose bad = pose;
  bad.position.x = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(selector.select(store, bad, req).ok());
  SelectorConfig cfg;
  cfg.global_fraction = 1.5;
  Selector misconfigured(cfg);
  r = misconfigured.select(store, pose, req);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("global_fraction"), std::string::npos);
  const std::vector<std::uint8_t> short_mask(10, 1);
  EXPECT_FALSE(selector.select(store, pose, req, short_mask).ok());
}

TEST(SelectorBudget, DeterministicWithTiesById) {
  // Identical Gaussians: every utility ties, so the lowest ids must win.
  SceneStore store;
  ASSERT_TRUE(store.begin_next_epoch().ok());
  std::vector<GaussianId> ids;
  for (int i = 0; i < 1000; ++i) {
    Gaussian g;
    g.id = store.allocate_id();
    g.position = glm::vec3(0.0f, 0.0f, 3.0f);
    ids.push_back(g.id);
    ASSERT_TRUE(store.insert(g).ok());
  }
  ASSERT_TRUE(store.commit_epoch().ok());
  Selector selector;
  SelectionRequest req;
  req.budget = 100;
  auto sel = selector.select(store, ClientPose{}, req);
  ASSERT_TRUE(sel.ok()) << sel.message();
  EXPECT_EQ(sel->ids, std::vector<GaussianId>(ids.begin(), ids.begin() + 100));
  // Random scene: two fresh selectors agree exactly.
  SceneStore scene;
  test::fill_test_scene(scene, 20000, 9);
  std::mt19937_64 rng(4);
  const ClientPose pose = test::random_test_pose(rng);
  req.budget = 3000;
  req.query = SemanticQuery::for_class("plant");
  req.rho = 0.3;
  Selector a;
  Selector b;
  auto sa = a.select(scene, pose, req);
  auto sb = b.select(scene, pose, req);
  ASSERT_TRUE(sa.ok() && sb.ok());
  EXPECT_EQ(sa->ids, sb->ids);
}

// The selector ranks in id order internally: the order of the span must not matter.
// Sorted vs shuffled spans (dense ids: counting sort; ids spread wide: comparison sort;
// repeated identical Gaussians: ties by id) give the same sets over a walk with
// hysteresis, a query and an eligibility mask, and indices point at the right Gaussians.
TEST(SelectorBudget, SpanOrderDoesNotChangeTheSelection) {
  for (std::uint64_t id_stride : {std::uint64_t{1}, std::uint64_t{1000003}}) {
    std::mt19937_64 rng(21);
    std::vector<Gaussian> sorted;
    for (std::uint64_t i = 0; i < 6000; ++i) sorted.push_back(test::random_test_gaussian(rng, GaussianId{1 + i * id_stride}));
    for (std::size_t i = 0; i < 300; ++i) {  // a block of identical Gaussians: every utility ties
      Gaussian g = sorted[0];
      g.id = GaussianId{to_underlying(sorted.back().id) + id_stride};
      g.carrier = false;
      sorted.push_back(g);
    }
    std::vector<std::uint8_t> eligible_sorted(sorted.size());
    for (auto& e : eligible_sorted) e = (rng() % 10) != 0;
    std::vector<std::size_t> perm(sorted.size());
    for (std::size_t i = 0; i < perm.size(); ++i) perm[i] = i;
    std::shuffle(perm.begin(), perm.end(), rng);
    std::vector<Gaussian> shuffled(sorted.size());
    std::vector<std::uint8_t> eligible_shuffled(sorted.size());
    for (std::size_t i = 0; i < perm.size(); ++i) {
      shuffled[i] = sorted[perm[i]];
      eligible_shuffled[i] = eligible_sorted[perm[i]];
    }
    std::vector<SemanticObject> objects;
    for (int o = 0; o < test::kTestObjects; ++o) {
      SemanticObject obj;
      obj.id = ObjectId{o};
      obj.label = test::kTestLabels[o];
      objects.push_back(obj);
    }
    SelectionRequest req;
    req.budget = 1500;
    req.client_capacity = 4000;
    req.query = SemanticQuery::for_class("chair");
    req.rho = 0.25;
    Selector a;
    Selector b;
    ClientPose pose = test::random_test_pose(rng);
    for (int step = 0; step < 6; ++step) {
      pose.position.x += 0.05;
      pose.orientation = glm::angleAxis(0.04, glm::dvec3(0, 1, 0)) * pose.orientation;
      auto sa = a.select(sorted, objects, 1, Epoch{1}, pose, req, eligible_sorted);
      auto sb = b.select(shuffled, objects, 1, Epoch{1}, pose, req, eligible_shuffled);
      ASSERT_TRUE(sa.ok() && sb.ok()) << (sa.ok() ? sb.message() : sa.message());
      EXPECT_EQ(sa->ids, sb->ids) << "stride " << id_stride << " step " << step;
      EXPECT_EQ(sa->retained, sb->retained);
      EXPECT_EQ(sa->object_selected, sb->object_selected);
      ASSERT_EQ(sb->indices.size(), sb->ids.size());
      for (std::size_t k = 0; k < sb->ids.size(); ++k) {
        ASSERT_EQ(shuffled[sb->indices[k]].id, sb->ids[k]);
        ASSERT_EQ(sorted[sa->indices[k]].id, sa->ids[k]);
        ASSERT_TRUE(eligible_shuffled[sb->indices[k]]);
      }
    }
  }
}

TEST(SelectorBudget, SelectorsSharingTermsSelectWhatEachWouldAlone) {
  // A host's sessions share the per-Gaussian terms of the scene they read: each must select
  // what a Selector with its own terms selects (its own query, budget and hysteresis), through
  // epochs that change the scene, with the terms computed once per epoch. A Selector of
  // another span sharing the same set must not be handed the first span's terms. Then two
  // threads at once, as a host's worker pool ticks sessions.
  SceneStore store;
  test::fill_test_scene(store, 6000, 5);
  std::mt19937_64 rng(9);
  auto terms = std::make_shared<SelectorTerms>();
  Selector shared_a, shared_b, own_a, own_b, shared_copy, own_copy;
  for (Selector* s : {&shared_a, &shared_b, &shared_copy}) s->share_terms(terms);
  SelectionRequest chairs;
  chairs.budget = 900;
  chairs.client_capacity = 4000;
  chairs.query = SemanticQuery::for_class("chair");
  chairs.rho = 0.5;
  SelectionRequest plain = chairs;
  plain.budget = 1700;
  plain.query.reset();
  plain.rho = 0.0;
  ClientPose pa = test::random_test_pose(rng), pb = test::random_test_pose(rng);
  std::size_t epochs = 1;
  std::vector<Gaussian> copy;  // rewritten in place: one span, a new version with each epoch
  for (int step = 0; step < 9; ++step) {
    if (step % 3 == 2) {  // a new epoch: some Gaussians move, one goes
      ASSERT_TRUE(store.begin_next_epoch().ok());
      for (std::size_t i = std::size_t(step); i < store.gaussians().size(); i += 97) {
        Gaussian g = store.gaussians()[i];
        g.position.x += 0.3f;
        ASSERT_TRUE(store.modify(g).ok());
      }
      ASSERT_TRUE(store.remove(store.gaussians()[5].id).ok());
      ASSERT_TRUE(store.commit_epoch().ok());
      ++epochs;
    }
    pa.position.x += 0.04;
    pb.orientation = glm::angleAxis(0.05, glm::dvec3(0, 1, 0)) * pb.orientation;
    auto a = shared_a.select(store, pa, chairs);
    auto a0 = own_a.select(store, pa, chairs);
    auto b = shared_b.select(store, pb, plain);
    auto b0 = own_b.select(store, pb, plain);
    ASSERT_TRUE(a.ok() && a0.ok() && b.ok() && b0.ok());
    EXPECT_EQ(a->ids, a0->ids) << "step " << step;
    EXPECT_EQ(a->indices, a0->indices) << "step " << step;
    EXPECT_EQ(a->retained, a0->retained) << "step " << step;
    EXPECT_EQ(b->ids, b0->ids) << "step " << step;
    EXPECT_EQ(b->retained, b0->retained) << "step " << step;
    // Another span (a reversed copy, same version number) through the same shared set.
    copy.assign(store.gaussians().rbegin(), store.gaussians().rend());
    auto c = shared_copy.select(copy, store.objects(), to_underlying(store.epoch()), store.epoch(), pb, plain);
    auto c0 = own_copy.select(copy, store.objects(), to_underlying(store.epoch()), store.epoch(), pb, plain);
    ASSERT_TRUE(c.ok() && c0.ok());
    EXPECT_EQ(c->ids, c0->ids) << "step " << step;
    EXPECT_EQ(c->indices, c0->indices) << "step " << step;
  }
  // Per epoch one set for the store's two selectors and one for the copy's (which replaces
  // the store's as the shared latest, so the next epoch builds both again).
  EXPECT_EQ(terms->builds(), 2 * epochs);

  // Two threads, each a Selector on the shared terms, at a version neither has seen.
  auto threaded = std::make_shared<SelectorTerms>();
  std::vector<std::vector<GaussianId>> got(2);
  std::vector<std::thread> threads;
  for (int i = 0; i < 2; ++i)
    threads.emplace_back([&, i] {
      Selector s;
      s.share_terms(threaded);
      ClientPose p = pa;
      for (int k = 0; k < 4; ++k) {
        p.position.z += 0.05 * (i + 1);
        if (auto r = s.select(store, p, i ? plain : chairs); r.ok()) got[i] = r->ids;
      }
    });
  for (auto& t : threads) t.join();
  for (int i = 0; i < 2; ++i) {
    Selector s;
    ClientPose p = pa;
    std::vector<GaussianId> want;
    for (int k = 0; k < 4; ++k) {
      p.position.z += 0.05 * (i + 1);
      auto r = s.select(store, p, i ? plain : chairs);
      ASSERT_TRUE(r.ok());
      want = r->ids;
    }
    EXPECT_EQ(got[i], want) << "thread " << i;
  }
  EXPECT_EQ(threaded->builds(), 1u);
}

TEST(SelectorBudget, CarriersAndIneligibleNeverSelected) {
  SceneStore store;
  test::fill_test_scene(store, 5000, 6);
  std::vector<std::uint8_t> eligible(store.gaussians().size());
  for (std::size_t i = 0; i < eligible.size(); ++i) eligible[i] = (i % 3) != 0;
  Selector selector;
  SelectionRequest req;
  req.budget = 5000;
  req.client_capacity = 5000;
  auto sel = selector.select(store, ClientPose{}, req, eligible);
  ASSERT_TRUE(sel.ok()) << sel.message();
  std::size_t expect = 0;
  for (std::size_t i = 0; i < eligible.size(); ++i) expect += eligible[i] && !store.gaussians()[i].carrier;
  EXPECT_EQ(sel->ids.size(), expect);
  for (std::uint32_t i : sel->indices) {
    EXPECT_TRUE(eligible[i]);
    EXPECT_FALSE(store.gaussians()[i].carrier);
  }
}

TEST(SelectorBudget, TakesTheEligibilityFiltersVerdict) {
  SceneStore store;
  test::fill_test_scene(store, 5000, 16);
  EligibilityConfig cfg;
  cfg.min_opacity = 0.5f;  // about half of the test scene's opacities
  auto eligible = filter_eligible(store, cfg);
  ASSERT_TRUE(eligible.ok()) << eligible.message();
  ASSERT_GT(eligible->counts.removed_opacity, 0u);
  Selector selector;
  SelectionRequest req;
  req.budget = 5000;
  req.client_capacity = 5000;
  auto sel = selector.select(store, ClientPose{}, req, *eligible);
  ASSERT_TRUE(sel.ok()) << sel.message();
  EXPECT_EQ(sel->ids.size(), eligible->indices.size());
  for (std::uint32_t i : sel->indices) {
    EXPECT_TRUE(std::binary_search(eligible->indices.begin(), eligible->indices.end(), i));
  }
  EligibleSet stale = *eligible;
  stale.epoch = Epoch{99};
  EXPECT_FALSE(selector.select(store, ClientPose{}, req, stale).ok());
}

// Fraction of the view-layer picks that lie inside the (unwidened) frustum.
TEST(SelectorBudget, PrefersWhatTheHeadSeesAndKeepsAGlobalLayer) {
  SceneStore store;
  test::fill_test_scene(store, 40000, 8);
  ClientPose front;
  front.position = glm::dvec3(0.0, 1.5, 0.0);
  ClientPose back = front;
  back.orientation = glm::angleAxis(3.141592653589793, glm::dvec3(0, 1, 0));
  SelectionRequest req;
  req.budget = 8000;
  Selector a;
  Selector b;
  auto sa = a.select(store, front, req);
  auto sb = b.select(store, back, req);
  ASSERT_TRUE(sa.ok() && sb.ok());
  EXPECT_EQ(sa->global_selected, 1600u);
  // The global layer is pose-independent: at least it is shared by opposite views.
  std::vector<GaussianId> common;
  std::set_intersection(sa->ids.begin(), sa->ids.end(), sb->ids.begin(), sb->ids.end(), std::back_inserter(common));
  EXPECT_GE(common.size(), 1600u);
  // Looking along +z (OpenCV: z forward), most selected Gaussians are in front (z > 0).
  std::size_t ahead = 0;
  for (std::uint32_t i : sa->indices) ahead += store.gaussians()[i].position.z > 0.0f;
  EXPECT_GT(static_cast<double>(ahead) / static_cast<double>(sa->ids.size()), 0.75);
}

TEST(SelectorBudget, HysteresisKeepsSmallHeadMotionBelowOnePercent) {
  SceneStore store;
  test::fill_test_scene(store, 60000, 10);
  SelectionRequest req;
  req.budget = 12000;
  std::mt19937_64 rng(12);
  double worst = 0.0;
  double worst_without = 0.0;
  for (int trial = 0; trial < 8; ++trial) {
    ClientPose pose = test::random_test_pose(rng);
    ClientPose moved = pose;  // 5 cm and 2 degrees
    moved.position += glm::dvec3(0.05, 0.0, 0.0);
    moved.orientation = glm::angleAxis(2.0 * 3.141592653589793 / 180.0, glm::dvec3(0, 1, 0)) * pose.orientation;
    for (double bonus : {0.3, 0.0}) {
      SelectorConfig cfg;
      cfg.retention_bonus = bonus;
      Selector sel(cfg);
      ASSERT_TRUE(sel.select(store, pose, req).ok());
      auto settled = sel.select(store, pose, req);  // steady state at this pose
      auto next = sel.select(store, moved, req);
      ASSERT_TRUE(settled.ok() && next.ok());
      EXPECT_EQ(settled->retained, settled->ids.size());
      std::vector<GaussianId> entered;
      std::set_difference(next->ids.begin(), next->ids.end(), settled->ids.begin(), settled->ids.end(),
                          std::back_inserter(entered));
      const double f = static_cast<double>(entered.size()) / static_cast<double>(req.budget);
      (bonus > 0.0 ? worst : worst_without) = std::max(bonus > 0.0 ? worst : worst_without, f);
      std::printf("trial %d bonus %.1f entering %.4f\n", trial, bonus, f);
    }
  }
  std::printf("worst entering fraction after 5 cm + 2 deg: %.4f with bonus 0.3, %.4f without\n", worst,
              worst_without);
  EXPECT_LT(worst, 0.01) << "entering Gaussians per small head motion, fraction of M";
  // The bonus is what keeps it small: without it the same motion churns more.
  EXPECT_GT(worst_without, worst);
}

TEST(SelectorBudget, FruitDropsSegmentQueryReservesExactly) {
  GAUSS_REQUIRE_DATA(ply, "splats/fruit_drops_sh3.ply");
  GAUSS_REQUIRE_DATA(labels_path, "semantic/fruit_drops_labels.txt");
  auto scene = read_gaussian_ply(ply);
  ASSERT_TRUE(scene.ok()) << scene.message();
  auto labels = read_labels(labels_path);
  ASSERT_TRUE(labels.ok()) << labels.message();
  ASSERT_TRUE(check_label_count(*labels, scene->cloud.gaussians.size(), "labels", "ply").ok());
  SceneStore store;
  ASSERT_TRUE(store.begin_next_epoch().ok());
  ASSERT_TRUE(store.set_sh_degree(scene->cloud.sh_degree).ok());
  for (int k = 1; k <= 8; ++k) ASSERT_TRUE(store.set_object(ObjectId{k}, "segment_" + std::to_string(k)).ok());
  for (std::size_t i = 0; i < scene->cloud.gaussians.size(); ++i) {
    Gaussian g = scene->cloud.gaussians[i];
    g.id = store.allocate_id();
    g.object = (*labels)[i] > 0 ? ObjectId{(*labels)[i]} : kNoObject;
    ASSERT_TRUE(store.insert(g).ok());
  }
  ASSERT_TRUE(store.commit_epoch().ok());
  std::mt19937_64 rng(21);
  for (int k = 1; k <= 8; ++k) {
    const std::size_t members = static_cast<std::size_t>(std::count((*labels).begin(), (*labels).end(), k));
    for (const SemanticQuery& q :
         {SemanticQuery::for_instance(ObjectId{k}), SemanticQuery::for_class("SEGMENT_" + std::to_string(k))}) {
      Selector selector;
      SelectionRequest req;
      req.budget = 1000;
      req.query = q;
      req.rho = 0.9;
      ClientPose pose = test::random_test_pose(rng);
      pose.position = glm::dvec3(0.0);
      auto sel = selector.select(store, pose, req);
      ASSERT_TRUE(sel.ok()) << sel.message();
      EXPECT_EQ(count_in_objects(store, *sel, {ObjectId{k}}), std::min<std::size_t>(members, 900)) << "segment " << k;
      EXPECT_EQ(sel->ids.size(), 1000u);
    }
  }
}

}  // namespace
}  // namespace gauss
