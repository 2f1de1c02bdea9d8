// LodCutter and LodSelector: a cut never exceeds its budget and covers every leaf it stands for
// exactly once, refines what is near and in view, holds still under a standing pose, leaves a
// query's target out; the selector keeps the reservation's leaves and shares exactly and is
// the leaf selection itself where everything fits.
#include <algorithm>
#include <array>
#include <bit>
#include <limits>
#include <iterator>
#include <map>
#include <optional>
#include <random>
#include <cmath>
#include <set>
#include <thread>
#include <tuple>
#include <vector>

#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>

#include "gauss/engine/camera.h"
#include "gauss/engine/lod_cut.h"
#include "gauss/engine/lod_selector.h"
#include "gauss/engine/selector.h"
#include "host_world.h"
// The view terms the cutter ranks by, shared with the Selector (a private header): the
// reference greedy below scores nodes with the same float operations.
#include "../../engine/src/select/view_score.h"

using namespace gauss;

namespace {

using World = gauss::test::HostWorld;

LodHierarchy build(const World& w, const LodConfig& config = {}) {
  std::vector<std::uint32_t> all;
  for (std::size_t i = 0; i < w.store.gaussians().size(); ++i)
    if (!w.store.gaussians()[i].carrier) all.push_back(static_cast<std::uint32_t>(i));
  auto h = LodHierarchy::create(w.store.sh_degree(), config);
  EXPECT_TRUE(h.ok()) << h.message();
  auto r = h->update(w.store.gaussians(), all);
  EXPECT_TRUE(r.ok()) << r.message();
  return std::move(*h);
}

// The room's appearance Gaussians (the leaves build() puts in its hierarchy).
std::vector<Gaussian> appearance_leaves(const World& w) {
  std::vector<Gaussian> leaves;
  for (const Gaussian& g : w.store.gaussians())
    if (!g.carrier) leaves.push_back(g);
  return leaves;
}

// A head at `eye` looking at `at`, both given as fractions of the room's box (the room's
// world is y down), with a 62-degree horizontal field of view.
const World* g_world = nullptr;
glm::dvec3 in_room(glm::dvec3 f) {
  const auto& b = g_world->store.bounds();
  return glm::dvec3(b.min) + f * glm::dvec3(b.max - b.min);
}
ClientPose look(glm::dvec3 eye, glm::dvec3 at) {
  const glm::dmat4 c2w = opencv_look_at(in_room(eye), in_room(at), glm::dvec3(0, -1, 0));
  ClientPose p;
  p.position = glm::dvec3(c2w[3]);
  p.orientation = glm::quat_cast(glm::dmat3(c2w));
  p.tan_half_fov_x = 0.6;
  p.tan_half_fov_y = 0.45;
  return p;
}

// Leaf ids under pool node n.
void leaves_under(const LodHierarchy& h, std::uint32_t n, std::vector<GaussianId>& out) {
  const LodNode& node = h.node(n);
  if (node.leaf) {
    out.push_back(node.id);
    return;
  }
  for (std::uint32_t c : h.children(node)) leaves_under(h, c, out);
}

// Every leaf under the cut, each once: checks the cut is a set of disjoint subtrees.
std::vector<GaussianId> covered(const LodHierarchy& h, const LodCut& cut) {
  std::vector<GaussianId> ids;
  for (std::uint32_t n : cut.nodes) leaves_under(h, n, ids);
  std::sort(ids.begin(), ids.end());
  EXPECT_TRUE(std::adjacent_find(ids.begin(), ids.end()) == ids.end()) << "a leaf is covered twice";
  return ids;
}

std::vector<std::uint32_t> sorted(std::vector<std::uint32_t> v) {
  std::sort(v.begin(), v.end());
  return v;
}

}  // namespace

TEST(LodCut, NeverExceedsTheBudgetAndCoversEveryLeafOnce) {
  World w;
  g_world = &w;
  const LodHierarchy h = build(w);
  ASSERT_GT(h.interior_count(), 0u);
  LodCutter cutter;
  for (const ClientPose& pose : {look({0.1, 0.5, 0.1}, {0.9, 0.5, 0.9}), look({0.9, 0.4, 0.9}, {0.1, 0.5, 0.2})}) {
    for (std::size_t budget : {std::size_t{1}, std::size_t{2}, std::size_t{3}, std::size_t{10}, std::size_t{100},
                               std::size_t{777}, h.leaf_count() - 1, h.leaf_count(), std::size_t{100000}}) {
      auto cut = cutter.cut(h, pose, budget);
      ASSERT_TRUE(cut.ok()) << cut.message();
      EXPECT_LE(cut->nodes.size(), budget);
      EXPECT_EQ(cut->leaves + cut->interior, cut->nodes.size());
      EXPECT_EQ(covered(h, *cut).size(), h.leaf_count()) << "budget " << budget;
      if (budget >= h.leaf_count()) {
        EXPECT_EQ(cut->interior, 0u) << "everything fits: every leaf";
      }
    }
  }
  auto none = cutter.cut(h, look({0.2, 0.5, 0.2}, {0.8, 0.5, 0.8}), 0);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->nodes.empty());
}

TEST(LodCut, RefinesWhatIsInViewMoreThanWhatIsBehind) {
  World w;
  g_world = &w;
  const LodHierarchy h = build(w);
  // From the room's centre: what lies in front and what lies behind are alike but for the view.
  const glm::dvec3 eye = in_room({0.5, 0.5, 0.5});
  const glm::dvec3 at = in_room({0.9, 0.5, 0.9});
  LodCutter cutter;
  auto cut = cutter.cut(h, look({0.5, 0.5, 0.5}, {0.9, 0.5, 0.9}), 300);
  ASSERT_TRUE(cut.ok());
  const glm::dvec3 forward = glm::normalize(at - eye);
  double front_leaves = 0, front_nodes = 0, back_leaves = 0, back_nodes = 0;
  for (std::uint32_t n : cut->nodes) {
    const LodNode& node = h.node(n);
    const glm::dvec3 d = glm::dvec3(node.centre) - eye;
    const double along = glm::dot(d, forward) / glm::length(d);
    if (along > 0.9) {  // within ~25 degrees of the view direction
      front_leaves += node.leaf_count;
      front_nodes += 1;
    } else if (along < -0.9) {  // as far behind
      back_leaves += node.leaf_count;
      back_nodes += 1;
    }
  }
  ASSERT_GT(front_nodes, 0);
  ASSERT_GT(back_nodes, 0);
  // Leaves per node: the view's side is finer.
  EXPECT_LT(front_leaves / front_nodes, back_leaves / back_nodes);
}

TEST(LodCut, AStandingPoseKeepsItsCutAndHysteresisDampsSmallMoves) {
  World w;
  g_world = &w;
  const LodHierarchy h = build(w);
  const glm::dvec3 at(0.9, 0.5, 0.9);
  auto churn = [&](double bonus) {
    SelectorConfig cfg;
    cfg.retention_bonus = bonus;
    LodCutter cutter(cfg);
    auto first = cutter.cut(h, look({0.1, 0.5, 0.1}, at), 400);
    EXPECT_TRUE(first.ok());
    auto again = cutter.cut(h, look({0.1, 0.5, 0.1}, at), 400);
    EXPECT_TRUE(again.ok());
    EXPECT_EQ(sorted(first->nodes), sorted(again->nodes)) << "same pose, same cut";
    EXPECT_EQ(again->retained, again->refined);
    // A sway of a few centimetres: count the nodes that change between consecutive cuts.
    std::size_t changed = 0;
    std::vector<std::uint32_t> prev = sorted(again->nodes);
    for (int i = 0; i < 8; ++i) {
      const double dx = (i % 2 ? 0.005 : -0.005);  // of the room: a few centimetres
      auto c = cutter.cut(h, look({0.1 + dx, 0.5, 0.1 - dx}, at), 400);
      EXPECT_TRUE(c.ok());
      std::vector<std::uint32_t> now = sorted(c->nodes), diff;
      std::set_symmetric_difference(prev.begin(), prev.end(), now.begin(), now.end(), std::back_inserter(diff));
      changed += diff.size();
      prev = std::move(now);
    }
    return changed;
  };
  const std::size_t damped = churn(0.3);
  const std::size_t free = churn(0.0);
  EXPECT_GT(free, 0u) << "the sway must move a cut without hysteresis, or this test shows nothing";
  EXPECT_LT(damped, free);
}

TEST(LodCut, ExcludedObjectsAreLeftOutAndNeverShownTwice) {
  World w;
  g_world = &w;
  const LodHierarchy h = build(w);
  // The object with the most leaves.
  std::map<std::int32_t, std::size_t> per_object;
  for (const Gaussian& g : w.store.gaussians())
    if (to_underlying(g.object) >= 0 && !g.carrier) ++per_object[to_underlying(g.object)];
  ASSERT_FALSE(per_object.empty());
  const auto target = std::max_element(per_object.begin(), per_object.end(),
                                       [](const auto& a, const auto& b) { return a.second < b.second; });
  const ObjectId o{target->first};
  ASSERT_GT(target->second, 8u) << "the target needs a subtree of its own";
  const std::vector<ObjectId> excluded{o, o, ObjectId{999999}};  // repeats and unknown objects are fine
  LodCutter cutter;
  for (std::size_t budget : {std::size_t{1}, std::size_t{5}, std::size_t{60}, std::size_t{600}, h.leaf_count()}) {
    auto cut = cutter.cut(h, look({0.1, 0.5, 0.1}, {0.9, 0.5, 0.9}), budget, excluded);
    ASSERT_TRUE(cut.ok());
    EXPECT_LE(cut->nodes.size(), budget);
    const std::vector<GaussianId> ids = covered(h, *cut);
    for (GaussianId id : ids) {
      EXPECT_NE(w.store.find(id)->object, o) << "the target shown in the cut";
    }
    if (budget >= 60) {
      EXPECT_EQ(ids.size(), h.leaf_count() - target->second) << "everything else is covered";
    }
  }
}

namespace {

// The greedy refinement as lod_cut.h states it, the plain way: a max-heap frontier from the
// root, ordered by effective priority p = min(error x hysteresis, p(parent)), then the
// shallower node, then the lower id; a node whose children do not fit stays. Excluded
// objects: a node all of whose leaves are excluded is left out, one that mixes is refined
// first (p = +inf). Returns the cut's pool indices and the refined nodes' ids.
struct ReferenceCut {
  std::vector<std::uint32_t> nodes;  // sorted
  std::set<std::uint64_t> refined;
  std::size_t retained{0};
};
ReferenceCut reference_cut(const LodHierarchy& h, const ClientPose& pose, std::size_t budget,
                           const SelectorConfig& cfg, const std::set<std::uint64_t>& previous,
                           const std::set<std::int32_t>& excluded = {}) {
  ReferenceCut out;
  if (budget == 0 || h.root() == kNoLodNode) return out;
  // 0: no excluded leaf under it, 1: only excluded leaves, 2: both.
  std::map<std::uint32_t, int> state;
  auto state_of = [&](auto&& self, std::uint32_t n) -> int {
    if (auto it = state.find(n); it != state.end()) return it->second;
    const LodNode& node = h.node(n);
    int s = 0;
    if (node.leaf) {
      s = excluded.count(to_underlying(h.leaf_gaussian(node).object)) ? 1 : 0;
    } else {
      bool any_in = false, any_out = false;
      for (std::uint32_t c : h.children(node)) {
        const int cs = self(self, c);
        any_in |= cs != 0;
        any_out |= cs != 1;
      }
      s = any_in ? (any_out ? 2 : 1) : 0;
    }
    return state[n] = s;
  };
  if (state_of(state_of, h.root()) == 1) return out;
  if (h.node(h.root()).leaf) {
    out.nodes.push_back(h.root());
    return out;
  }
  const select_detail::ViewParams vp = select_detail::make_view_params(pose, cfg);
  auto key_of = [&](std::uint32_t n) {
    const LodNode& node = h.node(n);
    if (state_of(state_of, n) == 2) return std::numeric_limits<float>::infinity();
    const std::uint8_t resident = previous.count(to_underlying(node.id)) ? 1 : 0;
    std::uint32_t key = 0;
    select_detail::score_view_spheres(1, &node.centre.x, &node.centre.y, &node.centre.z, &node.radius, &resident, vp,
                                      &key);
    return std::bit_cast<float>(key);
  };
  struct Frontier {
    float p;
    int depth;
    std::uint64_t id;
    std::uint32_t n;
  };
  auto lower = [](const Frontier& a, const Frontier& b) {
    if (a.p != b.p) return a.p < b.p;
    if (a.depth != b.depth) return a.depth > b.depth;
    return a.id > b.id;
  };
  std::vector<Frontier> heap{{key_of(h.root()), 0, to_underlying(h.node(h.root()).id), h.root()}};
  std::size_t count = 1;
  while (!heap.empty() && count < budget) {
    std::pop_heap(heap.begin(), heap.end(), lower);
    const Frontier f = heap.back();
    heap.pop_back();
    const LodNode& node = h.node(f.n);
    std::size_t children = 0;
    for (std::uint32_t c : h.children(node)) children += state_of(state_of, c) != 1;
    if (count - 1 + children > budget && f.p != std::numeric_limits<float>::infinity()) {
      out.nodes.push_back(f.n);
      continue;
    }
    count = count - 1 + children;
    out.refined.insert(to_underlying(node.id));
    out.retained += previous.count(to_underlying(node.id));
    for (std::uint32_t c : h.children(node)) {
      if (state_of(state_of, c) == 1) continue;
      const LodNode& child = h.node(c);
      if (child.leaf) {
        out.nodes.push_back(c);
      } else {
        heap.push_back(Frontier{std::min(key_of(c), f.p), f.depth + 1, to_underlying(child.id), c});
        std::push_heap(heap.begin(), heap.end(), lower);
      }
    }
  }
  for (const Frontier& f : heap) out.nodes.push_back(f.n);
  std::sort(out.nodes.begin(), out.nodes.end());
  return out;
}

// The cut's parallel arrays: leaves then interior nodes, each by ascending id, and each
// entry's id and place those of its node.
void expect_cut_arrays(const LodHierarchy& h, const LodCut& cut) {
  ASSERT_EQ(cut.ids.size(), cut.nodes.size());
  ASSERT_EQ(cut.places.size(), cut.nodes.size());
  for (std::size_t i = 0; i < cut.nodes.size(); ++i) {
    const LodNode& node = h.node(cut.nodes[i]);
    EXPECT_EQ(cut.ids[i], to_underlying(node.id));
    EXPECT_EQ(node.leaf, i < cut.leaves);
    EXPECT_EQ(cut.places[i], node.leaf ? h.leaf_source(node) : h.record_slot(node));
    if (i > 0 && i != cut.leaves) {
      EXPECT_LT(cut.ids[i - 1], cut.ids[i]);
    }
  }
}

}  // namespace

// The cutter skips the heap (a histogram of priorities, one sorted bucket, a small heap for
// the last fits) and keeps a breadth-first copy of the tree: the same cut as the plain greedy,
// node for node, over a walk with hysteresis, budgets from 1 up, a hierarchy updated between
// cuts (the copy rebuilt, the hysteresis carried by id) and a query's target excluded.
TEST(LodCut, EqualsThePlainGreedyRefinement) {
  World w;
  g_world = &w;
  const std::vector<Gaussian> leaves = appearance_leaves(w);
  LodHierarchy h = build(w);
  // The object with the most leaves, for the excluded steps.
  std::map<std::int32_t, std::size_t> per_object;
  for (const Gaussian& g : leaves)
    if (to_underlying(g.object) >= 0) ++per_object[to_underlying(g.object)];
  ASSERT_FALSE(per_object.empty());
  const std::int32_t target =
      std::max_element(per_object.begin(), per_object.end(), [](auto& a, auto& b) { return a.second < b.second; })->first;

  SelectorConfig cfg;
  LodCutter cutter(cfg);
  std::set<std::uint64_t> previous;
  const std::size_t n = h.leaf_count();
  const std::vector<std::size_t> budgets{1, 2, 7, 50, 333, n / 3, n / 3, n / 3 + 1, n - 1, n, 4000, 600, 600, 600};
  std::size_t compared = 0, rebuilt = 0;
  for (std::size_t step = 0; step < budgets.size(); ++step) {
    if (step == 10) {
      // Every 7th leaf leaves and another moves: nodes retire, others take new ids.
      std::vector<Gaussian> fewer;
      for (std::size_t i = 0; i < leaves.size(); ++i)
        if (i % 7 != 3) fewer.push_back(leaves[i]);
      fewer[5].position += glm::vec3(0.3f);
      auto r = h.update(fewer);
      ASSERT_TRUE(r.ok()) << r.message();
      ASSERT_FALSE(r->removed.empty());
    }
    const double t = double(step) / double(budgets.size());
    const ClientPose pose = look({0.1 + 0.6 * t, 0.5, 0.1 + 0.02 * step}, {0.9, 0.5 - 0.2 * t, 0.9});
    std::set<std::int32_t> excluded_set;
    std::vector<ObjectId> excluded;
    if (step >= 12) {
      excluded_set.insert(target);
      excluded = {ObjectId{target}};
    }
    auto cut = cutter.cut(h, pose, budgets[step], excluded);
    ASSERT_TRUE(cut.ok()) << cut.message();
    expect_cut_arrays(h, *cut);
    rebuilt += cut->layout_rebuilt;
    const ReferenceCut ref = reference_cut(h, pose, budgets[step], cfg, previous, excluded_set);
    EXPECT_EQ(sorted(cut->nodes), ref.nodes) << "step " << step << ", budget " << budgets[step];
    EXPECT_EQ(cut->refined, ref.refined.size()) << "step " << step;
    EXPECT_EQ(cut->retained, ref.retained) << "step " << step;
    compared += ref.nodes.size();
    previous = ref.refined;
  }
  EXPECT_EQ(rebuilt, 2u) << "a layout for the first cut and one after the update";
  EXPECT_GT(compared, 5000u);

  // Every budget at one pose: the budget runs out in every bucket, between a parent and a
  // child of equal priority among them (the tie the depth breaks).
  const ClientPose pose = look({0.2, 0.4, 0.1}, {0.8, 0.6, 0.9});
  for (std::size_t budget = 1; budget <= h.leaf_count(); budget += 1 + budget / 64) {
    cutter.clear_previous();
    auto cut = cutter.cut(h, pose, budget);
    ASSERT_TRUE(cut.ok()) << cut.message();
    ASSERT_EQ(sorted(cut->nodes), reference_cut(h, pose, budget, cfg, {}).nodes) << "budget " << budget;
  }
}

TEST(LodCut, CuttersSharingLayoutsCutWhatEachWouldAloneWithOneLayoutPerGeneration) {
  // Sessions reading one hierarchy share its breadth-first copy: the cuts must be those of
  // cutters with their own copies, through a hierarchy update and with each cutter's own
  // hysteresis (different poses), and the copy is built once per generation. Then the same
  // from two threads at once, as a host's worker pool ticks sessions.
  World w;
  g_world = &w;
  const std::vector<Gaussian> leaves = appearance_leaves(w);
  LodHierarchy h = build(w);
  auto layouts = std::make_shared<LodCutLayouts>();
  SelectorConfig cfg;
  LodCutter shared_a(cfg), shared_b(cfg), own_a(cfg), own_b(cfg);
  shared_a.share_layouts(layouts);
  shared_b.share_layouts(layouts);
  for (int step = 0; step < 8; ++step) {
    if (step == 4) {
      std::vector<Gaussian> fewer;
      for (std::size_t i = 0; i < leaves.size(); ++i)
        if (i % 5 != 1) fewer.push_back(leaves[i]);
      fewer[3].position += glm::vec3(0.2f);
      ASSERT_TRUE(h.update(fewer).ok());
    }
    const double t = 0.05 * step;
    const ClientPose pa = look({0.1 + t, 0.5, 0.1}, {0.9, 0.5, 0.9});
    const ClientPose pb = look({0.9 - t, 0.4, 0.8}, {0.1, 0.5, 0.2});
    for (auto [shared, own, pose] : {std::tuple{&shared_a, &own_a, pa}, std::tuple{&shared_b, &own_b, pb}}) {
      ASSERT_TRUE(shared->cut_in_place(h, pose, 300).ok());
      ASSERT_TRUE(own->cut_in_place(h, pose, 300).ok());
      EXPECT_EQ(shared->last().nodes, own->last().nodes) << "step " << step;
      EXPECT_EQ(shared->last().places, own->last().places) << "step " << step;
      EXPECT_EQ(shared->last().retained, own->last().retained) << "step " << step;
    }
  }
  EXPECT_EQ(layouts->builds(), 2u) << "one layout before the update and one after, for both cutters";

  // Two threads, each with its own cutter on the shared layouts, against one cutter alone.
  ASSERT_TRUE(h.update(leaves).ok());  // a new generation: the threads race to build it
  std::vector<std::vector<std::uint32_t>> got(2), want(2);
  std::vector<std::thread> threads;
  for (int i = 0; i < 2; ++i)
    threads.emplace_back([&, i] {
      LodCutter c(cfg);
      c.share_layouts(layouts);
      for (int k = 0; k < 5; ++k)
        if (c.cut_in_place(h, look({0.2 + 0.1 * i, 0.5, 0.1 * k}, {0.8, 0.5, 0.9}), 250).ok()) got[i] = c.last().nodes;
    });
  for (auto& th : threads) th.join();
  for (int i = 0; i < 2; ++i) {
    LodCutter c(cfg);
    for (int k = 0; k < 5; ++k) ASSERT_TRUE(c.cut_in_place(h, look({0.2 + 0.1 * i, 0.5, 0.1 * k}, {0.8, 0.5, 0.9}), 250).ok());
    want[i] = c.last().nodes;
    EXPECT_EQ(got[i], want[i]) << "thread " << i;
  }
  EXPECT_EQ(layouts->builds(), 3u);
}

TEST(LodCut, SharedLayoutsAreBuiltIntoTheSpareOnceNoCutterHoldsIt) {
  // The layouts keep the one before the latest and build the next into its memory, but not
  // while a cutter still cuts on it. The cuts are the same either way.
  World w;
  g_world = &w;
  const std::vector<Gaussian> leaves = appearance_leaves(w);
  LodHierarchy h = build(w);
  auto layouts = std::make_shared<LodCutLayouts>();
  LodCutter follows(SelectorConfig{}), lingers(SelectorConfig{});
  follows.share_layouts(layouts);
  lingers.share_layouts(layouts);
  const ClientPose pose = look({0.1, 0.5, 0.1}, {0.9, 0.5, 0.9});
  ASSERT_TRUE(follows.cut_in_place(h, pose, 300).ok());
  ASSERT_TRUE(lingers.cut_in_place(h, pose, 300).ok());  // and stays on the first layout
  for (int generation = 2; generation <= 4; ++generation) {
    ASSERT_TRUE(h.update(leaves).ok());  // the same leaves: a new generation all the same
    ASSERT_TRUE(follows.cut_in_place(h, pose, 300).ok());
  }
  // Generation 2 had no spare; 3's spare was the first layout, which `lingers` holds; 4's was
  // the second, which `follows` had left.
  EXPECT_EQ(layouts->builds(), 4u);
  EXPECT_EQ(layouts->reuses(), 1u);
  ASSERT_TRUE(lingers.cut_in_place(h, pose, 300).ok());
  LodCutter alone(SelectorConfig{});
  ASSERT_TRUE(alone.cut_in_place(h, pose, 300).ok());
  EXPECT_EQ(follows.last().nodes, alone.last().nodes);
  EXPECT_EQ(follows.last().places, alone.last().places);
  EXPECT_EQ(layouts->builds(), 4u) << "the latest serves every cutter";
}

TEST(LodCut, BadPoseOrConfigIsAnError) {
  World w;
  g_world = &w;
  const LodHierarchy h = build(w);
  ClientPose bad = look({0.2, 0.5, 0.2}, {0.8, 0.5, 0.8});
  bad.position.x = std::nan("");
  LodCutter cutter;
  EXPECT_FALSE(cutter.cut(h, bad, 10).ok());
  SelectorConfig cfg;
  cfg.out_of_view_weight = 0.0;
  LodCutter broken(cfg);
  EXPECT_FALSE(broken.cut(h, look({0.2, 0.5, 0.2}, {0.8, 0.5, 0.8}), 10).ok());
}

namespace {

// Checks a selection's shape: ids strictly ascending, each index naming its id.
void expect_well_formed(const Selection& s, const World& w, const LodSelector& lod) {
  const auto scene = w.store.gaussians();
  const auto extra = lod.records();
  ASSERT_EQ(s.ids.size(), s.indices.size());
  for (std::size_t k = 0; k < s.ids.size(); ++k) {
    if (k > 0) {
      EXPECT_LT(s.ids[k - 1], s.ids[k]);
    }
    const std::uint32_t i = s.indices[k];
    if (is_lod_interior_id(s.ids[k])) {
      ASSERT_GE(i, scene.size());
      ASSERT_LT(i - scene.size(), extra.size());
      EXPECT_EQ(lod.find_interior(s.ids[k]), &extra[i - scene.size()]);
    } else {
      ASSERT_LT(i, scene.size());
      EXPECT_EQ(scene[i].id, s.ids[k]);
    }
  }
}

// The leaf selection, then `lod`'s, checked well formed (an empty selection after a failure).
Selection select_with_lod(const World& w, Selector& leaves, LodSelector& lod, const ClientPose& pose,
                          const SelectionRequest& req) {
  auto leaf = leaves.select(w.store, pose, req);
  EXPECT_TRUE(leaf.ok()) << leaf.message();
  if (!leaf.ok()) return {};
  auto sel = lod.select(*leaf, w.store, pose, req);
  EXPECT_TRUE(sel.ok()) << sel.message();
  if (!sel.ok()) return {};
  expect_well_formed(*sel, w, lod);
  return std::move(*sel);
}

// `lod`'s selection at budget M is a plain Selector's, id for id and index for index.
void expect_leaf_selection(const World& w, LodSelector& lod, std::size_t budget) {
  SelectionRequest req;
  req.budget = req.client_capacity = budget;
  const ClientPose pose = look({0.1, 0.5, 0.1}, {0.9, 0.5, 0.9});
  Selector a, b;
  auto plain = a.select(w.store, pose, req);
  auto leaf = b.select(w.store, pose, req);
  ASSERT_TRUE(plain.ok() && leaf.ok());
  auto sel = lod.select(*leaf, w.store, pose, req);
  ASSERT_TRUE(sel.ok()) << sel.message();
  EXPECT_EQ(sel->ids, plain->ids);
  EXPECT_EQ(sel->indices, plain->indices);
  EXPECT_EQ(sel->lod_interior, 0u);
}

}  // namespace

TEST(LodSelector, TheReservationIsTheSelectorsOwnAndSharesAreExact) {
  World w;
  g_world = &w;
  const ObjectId o = w.store.objects().front().id;
  SelectionRequest req;
  req.budget = req.client_capacity = 400;
  req.query = SemanticQuery::for_instance(o);
  req.rho = 0.7;
  const ClientPose pose = look({0.1, 0.5, 0.1}, {0.9, 0.5, 0.9});
  Selector leaves_only;
  auto plain = leaves_only.select(w.store, pose, req);
  ASSERT_TRUE(plain.ok());
  ASSERT_GT(plain->background_candidates, req.budget) << "the background must not fit, or no cut is made";
  Selector leaves;
  LodSelector lod(w.store.sh_degree());
  ASSERT_TRUE(lod.update(w.store, nullptr).ok());
  std::optional<Selection> sel;
  ASSERT_NO_FATAL_FAILURE(sel = select_with_lod(w, leaves, lod, pose, req));
  EXPECT_LE(sel->ids.size(), req.budget);
  EXPECT_GT(sel->lod_interior, 0u);
  EXPECT_EQ(sel->object_selected, std::min(plain->object_candidates, std::size_t(std::floor(0.7 * 400))));
  // The target's leaves are exactly the leaf selection's; nothing else stands for them.
  auto target_leaves = [&](const Selection& s) {
    std::vector<GaussianId> out;
    for (std::size_t k = 0; k < s.ids.size(); ++k) {
      if (is_lod_interior_id(s.ids[k])) {
        EXPECT_NE(lod.find_interior(s.ids[k])->object, o) << "an interior record stands for the target";
        continue;
      }
      if (w.store.gaussians()[s.indices[k]].object == o) out.push_back(s.ids[k]);
    }
    return out;
  };
  EXPECT_EQ(target_leaves(*sel), target_leaves(*plain));
  EXPECT_EQ(target_leaves(*sel).size(), sel->object_selected);
  EXPECT_EQ(sel->ids.size(), sel->object_selected + sel->background_selected);
}

// Without a query (and without an eligibility filter) there is no reservation, and the cut
// stands in for the whole background: the Selector is not asked (its per-Gaussian terms were
// an O(N) pass per epoch for a count the scene keeps). The selections are what asking it
// gives, through queries coming and going and a new epoch, hysteresis included.
TEST(LodSelector, WithoutAQueryTheSelectorIsNotAskedAndTheSelectionIsTheSame) {
  World w;
  g_world = &w;
  const ObjectId o = w.store.objects().front().id;
  LodSelector fast(w.store.sh_degree()), asked(w.store.sh_degree());
  ASSERT_TRUE(fast.update(w.store, nullptr).ok());
  ASSERT_TRUE(asked.update(w.store, nullptr).ok());
  Selector fast_leaves, asked_leaves;
  auto terms = std::make_shared<SelectorTerms>();
  fast_leaves.share_terms(terms);
  std::mt19937_64 rng(23);
  for (int step = 0; step < 16; ++step) {
    if (step == 10) {  // a new epoch: some Gaussians recoloured
      ASSERT_TRUE(w.store.begin_next_epoch().ok());
      std::vector<Gaussian> edits;
      for (const Gaussian& g : w.store.gaussians())
        if (!g.carrier && rng() % 10 == 0) edits.push_back(g);
      for (Gaussian& g : edits) {
        g.sh_dc.x = -g.sh_dc.x;
        ASSERT_TRUE(w.store.modify(g).ok());
      }
      ASSERT_TRUE(w.store.commit_epoch().ok());
      ASSERT_TRUE(fast.update(w.store, nullptr).ok());
      ASSERT_TRUE(asked.update(w.store, nullptr).ok());
    }
    SelectionRequest req;
    req.budget = req.client_capacity = 400;
    const bool query = (step >= 4 && step < 7) || step >= 13;
    if (query) {
      req.query = SemanticQuery::for_instance(o);
      req.rho = 0.7;
    }
    const double a = 0.3 * step;
    const ClientPose pose = look({0.5 + 0.3 * std::cos(a), 0.5, 0.5 + 0.3 * std::sin(a)}, {0.5, 0.4, 0.5});
    auto got = fast.select(fast_leaves, w.store, nullptr, pose, req);
    SelectionRequest leaf_req = req;
    leaf_req.background_leaves = false;
    auto leaves = asked_leaves.select(w.store, pose, leaf_req);
    ASSERT_TRUE(got.ok() && leaves.ok()) << got.message() << leaves.message();
    auto want = asked.select(std::move(*leaves), w.store, pose, req);
    ASSERT_TRUE(want.ok()) << want.message();
    EXPECT_GT(got->lod_interior, 0u) << "step " << step;
    EXPECT_EQ(got->ids, want->ids) << "step " << step;
    EXPECT_EQ(got->indices, want->indices) << "step " << step;
    EXPECT_EQ(got->epoch, want->epoch);
    EXPECT_EQ(got->scene_size, want->scene_size);
    EXPECT_EQ(got->budget, want->budget);
    EXPECT_EQ(got->object_budget, want->object_budget);
    EXPECT_EQ(got->object_candidates, want->object_candidates);
    EXPECT_EQ(got->background_candidates, want->background_candidates) << "step " << step;
    EXPECT_EQ(got->object_selected, want->object_selected);
    EXPECT_EQ(got->background_selected, want->background_selected);
    EXPECT_EQ(got->global_selected, want->global_selected);
    EXPECT_EQ(got->retained, want->retained) << "step " << step;
    EXPECT_EQ(got->lod_interior, want->lod_interior);
    EXPECT_EQ(got->query.has_value(), want->query.has_value());
    // Terms are built only for the query's steps: the first query, and the query after the
    // new epoch.
    EXPECT_EQ(terms->builds(), step < 4 ? 0u : step < 13 ? 1u : 2u) << "step " << step;
  }
}

TEST(LodSelector, WhereTheBackgroundFitsTheSelectionIsTheLeafSelection) {
  World w;
  g_world = &w;
  LodSelector lod(w.store.sh_degree());
  ASSERT_TRUE(lod.update(w.store, nullptr).ok());
  expect_leaf_selection(w, lod, 5000);  // > N
}

TEST(LodSelector, AHierarchyThatCannotBeBuiltFallsBackToLeavesAndSaysSoOnce) {
  World w;
  g_world = &w;
  EligibleSet broken;
  broken.epoch = w.store.epoch();
  broken.indices = {0, 1, 1, 2};  // a Gaussian twice: the hierarchy refuses it
  LodSelector lod(w.store.sh_degree());
  const Status first = lod.update(w.store, &broken);
  ASSERT_FALSE(first.ok());
  EXPECT_NE(first.message().find("selecting leaves"), std::string::npos) << first.message();
  EXPECT_TRUE(lod.update(w.store, &broken).ok()) << "one line per epoch, not per tick";
  EXPECT_EQ(lod.hierarchy(), nullptr);
  expect_leaf_selection(w, lod, 100);
  // A stale eligible set is refused.
  EligibleSet stale;
  stale.epoch = Epoch{to_underlying(w.store.epoch()) + 5};
  LodSelector other(w.store.sh_degree());
  EXPECT_FALSE(other.update(w.store, &stale).ok());
}

TEST(LodSelector, CodecRangeReachesEveryInteriorRecord) {
  World w;
  g_world = &w;
  // The bound holds for any hierarchy inside the box: the room's, and its coarsest records.
  for (const float leaf_max : {-5.0f, 1.0f}) {
    CodecParams p = w.params;
    p.log_scale_max = leaf_max;
    const CodecParams fitted = fit_lod_codec_params(p);
    const LodHierarchy h = build(w);
    float widest = -100.0f;
    for (const LodNode& n : h.nodes())
      if (n.live && !n.leaf)
        widest = std::max({widest, h.record(n).log_scale.x, h.record(n).log_scale.y, h.record(n).log_scale.z});
    EXPECT_GE(fitted.log_scale_max, widest) << "an interior record would be clamped";
    EXPECT_GE(fitted.log_scale_max, leaf_max);
    EXPECT_EQ(fitted.box, p.box);
    EXPECT_EQ(fitted.log_scale_min, p.log_scale_min);
    EXPECT_EQ(fitted.dc_min, p.dc_min);
    // Not a wild over-estimate: within a factor 4 of the root's scale (the bound uses the
    // box's half-diagonal, the root the scene's own spread).
    EXPECT_LT(fitted.log_scale_max, std::max(widest, leaf_max) + std::log(4.0f));
  }
  // A degenerate (empty) box leaves the range as it was.
  CodecParams flat = w.params;
  flat.box.max = flat.box.min;
  EXPECT_EQ(fit_lod_codec_params(flat).log_scale_max, flat.log_scale_max);
}

TEST(LodSelector, EpochsFromTheChangeLogKeepTheHierarchyAFullBuildsAndIndicesTrue) {
  // Removals fill their places with the scene's last Gaussians (SceneStore::commit_epoch): a
  // leaf's remembered index must never name another Gaussian afterwards.
  World w;
  g_world = &w;
  LodSelector lod(w.store.sh_degree());
  ASSERT_TRUE(lod.update(w.store, nullptr).ok());
  SelectionRequest req;
  req.budget = req.client_capacity = 400;
  const ClientPose pose = look({0.1, 0.5, 0.1}, {0.9, 0.5, 0.9});
  Selector leaves;
  for (int epoch = 0; epoch < 4; ++epoch) {
    ASSERT_TRUE(w.store.begin_next_epoch().ok());
    const std::vector<Gaussian> now(w.store.gaussians().begin(), w.store.gaussians().end());
    for (std::size_t i = static_cast<std::size_t>(epoch); i < now.size(); i += 37) ASSERT_TRUE(w.store.remove(now[i].id).ok());
    for (std::size_t i = 5; i < now.size(); i += 53) {
      Gaussian g = now[i];
      if (!w.store.find(g.id)) continue;
      g.position += glm::vec3(0.05f, 0.0f, -0.02f);
      ASSERT_TRUE(w.store.modify(g).ok());
    }
    for (int k = 0; k < 30; ++k) {
      Gaussian g = now[static_cast<std::size_t>(k * 11 + epoch)];
      g.id = w.store.allocate_id();
      g.position += glm::vec3(0.1f);
      ASSERT_TRUE(w.store.insert(g).ok());
    }
    ASSERT_TRUE(w.store.commit_epoch().ok());
    ASSERT_TRUE(lod.update(w.store, nullptr).ok());
    ASSERT_NO_FATAL_FAILURE(select_with_lod(w, leaves, lod, pose, req));
  }
  // The same tree as a full build of the final scene in the same cube (the tree is a function
  // of the leaves and the cube): the same interior records, bit for bit.
  auto records_of = [](const LodHierarchy& h) {
    std::vector<std::array<float, 7>> r;
    for (const LodNode& n : h.nodes())
      if (n.live && !n.leaf) {
        const Gaussian& g = h.record(n);
        r.push_back({g.position.x, g.position.y, g.position.z, g.log_scale.x, g.log_scale.y, g.log_scale.z,
                     g.opacity_logit});
      }
    std::sort(r.begin(), r.end());
    return r;
  };
  ASSERT_NE(lod.hierarchy(), nullptr);
  LodConfig same_cube;
  same_cube.cube = lod.hierarchy()->cube();
  const LodHierarchy fresh = build(w, same_cube);
  EXPECT_EQ(lod.hierarchy()->leaf_count(), fresh.leaf_count());
  EXPECT_EQ(records_of(*lod.hierarchy()), records_of(fresh));
}
