// Eligibility filter: counts per rule (first failing rule), carriers apart, surface
// distance exact against brute force, bad configs rejected.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include "gauss/engine/eligibility.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/synthetic_scene.h"
#include "synthetic_test_scene.h"

namespace gauss {
namespace {

float logit(float p) { return std::log(p / (1.0f - p)); }

Gaussian good(std::uint64_t id, glm::vec3 p = glm::vec3(0.0f)) {
  Gaussian g;
  g.id = GaussianId{id};
  g.position = p;
  g.log_scale = glm::vec3(std::log(0.05f), std::log(0.05f), std::log(0.005f));
  g.opacity_logit = logit(0.9f);
  g.support = 10;
  return g;
}

TEST(Eligibility, CountsEachRuleOnce) {
  SceneStore s;
  ASSERT_TRUE(s.begin_next_epoch().ok());
  ASSERT_TRUE(s.insert(good(1)).ok());
  Gaussian faint = good(2);
  faint.opacity_logit = logit(0.01f);
  ASSERT_TRUE(s.insert(faint).ok());
  Gaussian huge = good(3);
  huge.log_scale.x = std::log(5.0f);
  huge.opacity_logit = logit(0.01f);  // also faint: counted under opacity (first rule) only
  ASSERT_TRUE(s.insert(huge).ok());
  Gaussian huge2 = good(4);
  huge2.log_scale.y = std::log(3.0f);
  ASSERT_TRUE(s.insert(huge2).ok());
  Gaussian speck = good(5);
  speck.log_scale = glm::vec3(std::log(1e-4f));
  ASSERT_TRUE(s.insert(speck).ok());
  Gaussian weak = good(6);
  weak.support = 1;
  ASSERT_TRUE(s.insert(weak).ok());
  Gaussian carrier = good(7);
  carrier.carrier = true;
  carrier.opacity_logit = logit(0.01f);
  ASSERT_TRUE(s.insert(carrier).ok());
  ASSERT_TRUE(s.insert(good(8)).ok());
  ASSERT_TRUE(s.commit_epoch().ok());

  EligibilityConfig c;
  c.min_opacity = 0.05f;
  c.max_scale = 1.0f;
  c.min_scale = 1e-3f;
  c.min_support = 3;
  auto r = filter_eligible(s, c);
  ASSERT_TRUE(r.ok()) << r.message();
  const EligibilityCounts& n = r->counts;
  EXPECT_EQ(n.carriers, 1u);
  EXPECT_EQ(n.considered, 7u);
  EXPECT_EQ(n.removed_opacity, 2u);
  EXPECT_EQ(n.removed_scale_large, 1u);
  EXPECT_EQ(n.removed_scale_small, 1u);
  EXPECT_EQ(n.removed_support, 1u);
  EXPECT_EQ(n.removed_surface, 0u);
  EXPECT_FALSE(n.surface_rule_applied);
  EXPECT_EQ(n.eligible, 2u);
  EXPECT_EQ(n.considered - n.eligible, n.removed_non_finite + n.removed_opacity + n.removed_scale_large +
                                           n.removed_scale_small + n.removed_support + n.removed_surface);
  ASSERT_EQ(r->indices.size(), 2u);
  EXPECT_EQ(s.gaussians()[r->indices[0]].id, GaussianId{1});
  EXPECT_EQ(s.gaussians()[r->indices[1]].id, GaussianId{8});
  EXPECT_EQ(r->epoch, s.epoch());

  // Everything off: all appearance Gaussians pass.
  EligibilityConfig off;
  off.min_opacity = 0.0f;
  off.max_scale = std::numeric_limits<float>::infinity();
  auto all = filter_eligible(s, off);
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(all->counts.eligible, 7u);
}

TEST(Eligibility, SurfaceDistanceRule) {
  SceneStore s;
  ASSERT_TRUE(s.begin_next_epoch().ok());
  SurfaceChunk floor;  // one 20 m quad at y = 0: too big for the grid, tested directly
  floor.chunk_id = 1;
  floor.mesh.positions = {{-10, 0, -10}, {10, 0, -10}, {10, 0, 10}, {-10, 0, 10}};
  floor.mesh.colors.assign(4, {200, 200, 200});
  floor.mesh.indices = {0, 2, 1, 0, 3, 2};
  ASSERT_TRUE(s.set_surface_chunk(floor).ok());
  SurfaceChunk tile;  // a small triangle up at y = 2
  tile.chunk_id = 2;
  tile.mesh.positions = {{0, 2, 0}, {0.1f, 2, 0}, {0, 2, 0.1f}};
  tile.mesh.colors.assign(3, {0, 0, 0});
  tile.mesh.indices = {0, 1, 2};
  ASSERT_TRUE(s.set_surface_chunk(tile).ok());
  ASSERT_TRUE(s.insert(good(1, {3, 0.01f, 3})).ok());    // on the floor
  ASSERT_TRUE(s.insert(good(2, {3, 0.5f, 3})).ok());     // floating
  ASSERT_TRUE(s.insert(good(3, {0.02f, 2.03f, 0.02f})).ok());  // on the tile
  ASSERT_TRUE(s.insert(good(4, {0.3f, 2.0f, 0.3f})).ok());     // beside the tile, in the air
  ASSERT_TRUE(s.commit_epoch().ok());
  EligibilityConfig c;
  c.max_surface_distance = 0.05f;
  auto r = filter_eligible(s, c);
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r->counts.surface_rule_applied);
  EXPECT_EQ(r->counts.removed_surface, 2u);
  ASSERT_EQ(r->indices.size(), 2u);
  EXPECT_EQ(s.gaussians()[r->indices[0]].id, GaussianId{1});
  EXPECT_EQ(s.gaussians()[r->indices[1]].id, GaussianId{3});
}

TEST(Eligibility, SurfaceIndexMatchesBruteForce) {
  SyntheticSceneConfig sc;
  sc.target_gaussians = 1000;
  sc.epochs = 1;
  auto scene = SyntheticScene::create(sc);
  ASSERT_TRUE(scene.ok());
  const TriangleMesh mesh = scene->surface_mesh();
  const TriangleMesh* meshes[] = {&mesh};
  const float d = 0.08f;
  SurfaceDistanceIndex index(meshes, d);
  ASSERT_FALSE(index.empty());
  std::uint64_t state = 12345;
  const auto rnd = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return float(state >> 40) / 16777216.0f;
  };
  const glm::vec3 lo = scene->room_min(), hi = scene->room_max();
  int near_count = 0;
  for (int k = 0; k < 400; ++k) {
    glm::vec3 p = lo + glm::vec3(rnd(), rnd(), rnd()) * (hi - lo);
    if (k % 2 == 0) p.y = 0.05f * rnd();  // half of them near the floor
    // Brute force: distance to every triangle, sampled densely by barycentric grid would be
    // approximate; use the analytic scene's distance (the mesh is exact on flat faces) only
    // where it is unambiguous: clearly inside or clearly outside the band.
    const float analytic = scene->distance_to_surface(p);
    if (std::abs(analytic - d) < 0.01f) continue;
    EXPECT_EQ(index.within(p, d), analytic < d) << p.x << "," << p.y << "," << p.z << " analytic " << analytic;
    near_count += analytic < d;
  }
  EXPECT_GT(near_count, 50);
}

TEST(Eligibility, BadConfigAndOpenEpochAreErrors) {
  SceneStore s;
  EligibilityConfig c;
  c.min_opacity = 1.5f;
  auto r = filter_eligible(s, c);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("min_opacity"), std::string::npos);
  c = {};
  c.max_scale = std::nanf("");
  EXPECT_FALSE(filter_eligible(s, c).ok());
  c = {};
  c.max_surface_distance = -1.0f;
  EXPECT_FALSE(filter_eligible(s, c).ok());
  c = {};
  c.min_scale = 3.0f;
  EXPECT_FALSE(filter_eligible(s, c).ok()) << "min_scale above max_scale";
  ASSERT_TRUE(s.begin_next_epoch().ok());
  EXPECT_FALSE(filter_eligible(s, EligibilityConfig{}).ok());
}

TEST(Eligibility, ConvergedSyntheticSceneLiesOnItsOwnSurfaceMesh) {
  SyntheticSceneConfig sc = test::small_synthetic_config(20000, 6);
  sc.converge_epochs = 2;
  auto scene = SyntheticScene::create(sc);
  ASSERT_TRUE(scene.ok());
  SceneStore s;
  ASSERT_NO_FATAL_FAILURE(test::produce_all(*scene, s));
  ASSERT_TRUE(s.begin_next_epoch().ok());
  ASSERT_TRUE(s.set_surface_chunk({0, Epoch{0}, scene->surface_mesh()}).ok());
  ASSERT_TRUE(s.commit_epoch().ok());
  EligibilityConfig c;
  c.max_surface_distance = 0.02f;  // the tessellation's chord error near sphere poles is ~1.5 cm
  auto r = filter_eligible(s, c);
  ASSERT_TRUE(r.ok());
  std::size_t converged = 0, converged_eligible = 0;
  std::vector<std::uint8_t> eligible(s.gaussians().size(), 0);
  for (auto i : r->indices) eligible[i] = 1;
  for (std::size_t i = 0; i < s.gaussians().size(); ++i) {
    const Gaussian& g = s.gaussians()[i];
    if (g.carrier || g.support != 1 + 3 * 2) continue;
    ++converged;
    converged_eligible += eligible[i];
  }
  EXPECT_GT(converged, 10000u);
  EXPECT_EQ(converged_eligible, converged) << "a converged Gaussian was judged off the surface";
  EXPECT_EQ(r->counts.carriers, s.carrier_count());
}

}  // namespace
}  // namespace gauss
