// Synthetic evolving scenes: config validation, determinism from the seed, Gaussians on
// the analytic surfaces without holes, convergence over epochs, pruning with fresh ids,
// carriers, objects, and exact ground-truth depth.
#include <cmath>
#include <set>
#include <unordered_map>

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include "gauss/engine/scene_store.h"
#include "gauss/engine/synthetic_scene.h"
#include "synthetic_test_scene.h"
#include "test_data.h"

namespace gauss {
namespace {

SyntheticSceneConfig small(int variant = 0, std::uint64_t seed = 7) {
  SyntheticSceneConfig c = test::small_synthetic_config(20000, 8);
  c.variant = variant;
  c.seed = seed;
  return c;
}

SyntheticScene make(const SyntheticSceneConfig& c) {
  auto s = SyntheticScene::create(c);
  EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.message());
  return std::move(s).value();
}

glm::vec3 world_point(const Camera& cam, std::uint32_t x, std::uint32_t y, float depth) {
  const glm::dvec3 pc((x + 0.5 - cam.cx) / cam.fx * depth, (y + 0.5 - cam.cy) / cam.fy * depth, depth);
  const glm::dmat3 r(cam.world_to_camera);
  const glm::dvec3 t(cam.world_to_camera[3]);
  return glm::vec3(glm::transpose(r) * (pc - t));
}

TEST(SyntheticScene, RejectsBadConfigNamingTheField) {
  const auto expect_bad = [](SyntheticSceneConfig c, const char* field) {
    auto s = SyntheticScene::create(c);
    ASSERT_FALSE(s.ok()) << field;
    EXPECT_NE(s.message().find(field), std::string::npos) << s.message();
  };
  auto c = small();
  c.variant = 4;
  expect_bad(c, "variant");
  c = small();
  c.target_gaussians = 0;
  expect_bad(c, "target_gaussians");
  c = small();
  c.epochs = 0;
  expect_bad(c, "epochs");
  c = small();
  c.prune_fraction = std::nanf("");
  expect_bad(c, "prune_fraction");
  c = small();
  c.focal_px = -1.0;
  expect_bad(c, "focal_px");
}

TEST(SyntheticScene, DeterministicFromSeed) {
  SceneStore a, b, other;
  auto sa = make(small(1, 42)), sb = make(small(1, 42)), so = make(small(1, 43));
  test::produce_all(sa, a);
  test::produce_all(sb, b);
  test::produce_all(so, other);
  ASSERT_EQ(a.size(), b.size());
  const auto ga = a.gaussians(), gb = b.gaussians();
  for (std::size_t i = 0; i < ga.size(); ++i) {
    ASSERT_EQ(ga[i].id, gb[i].id);
    ASSERT_EQ(ga[i].position, gb[i].position) << i;
    ASSERT_EQ(ga[i].sh_dc, gb[i].sh_dc) << i;
    ASSERT_EQ(ga[i].opacity_logit, gb[i].opacity_logit) << i;
    ASSERT_EQ(ga[i].rotation, gb[i].rotation) << i;
  }
  bool differs = other.size() != a.size();
  for (std::size_t i = 0; !differs && i < ga.size(); ++i) differs = other.gaussians()[i].position != ga[i].position;
  EXPECT_TRUE(differs) << "another seed produced the same scene";
}

TEST(SyntheticScene, ObjectsCarriersAndLabels) {
  for (int variant = 0; variant < 4; ++variant) {
    SceneStore store;
    auto cfg = small(variant);
    auto scene = make(cfg);
    test::produce_all(scene, store);
    std::multiset<std::string> labels;
    for (const auto& o : scene.objects()) labels.insert(o.label);
    EXPECT_GE(labels.count("chair"), 2u) << variant;
    for (const char* l : {"table", "plant", "keyboard", "robot_arm", "shelf"})
      EXPECT_GE(labels.count(l), 1u) << "variant " << variant << " lacks " << l;
    // Every object was looked at, declared with its label and has appearance members inside
    // its analytic extent (jitter of young Gaussians allowed for).
    ASSERT_EQ(store.objects().size(), scene.objects().size()) << variant;
    for (const auto& info : scene.objects()) {
      const SemanticObject* o = store.find_object(info.id);
      ASSERT_NE(o, nullptr);
      EXPECT_EQ(o->label, info.label);
      EXPECT_FALSE(o->members.empty()) << info.label;
      EXPECT_GT(o->quality, 0.0f);
      EXPECT_LE(o->quality, 1.0f);
      const glm::vec3 slack(0.1f);  // young Gaussians jitter up to 0.6 spacing
      EXPECT_TRUE(glm::all(glm::greaterThanEqual(o->extent_min, info.extent_min - slack))) << info.label;
      EXPECT_TRUE(glm::all(glm::lessThanEqual(o->extent_max, info.extent_max + slack)))
          << info.label << " variant " << variant << " store max " << o->extent_max.x << "," << o->extent_max.y << ","
          << o->extent_max.z << " analytic " << info.extent_max.x << "," << info.extent_max.y << "," << info.extent_max.z;
    }
    EXPECT_EQ(store.carrier_count(), scene.objects().size() * std::size_t(cfg.carriers_per_object)) << variant;
    for (const Gaussian& g : store.gaussians()) {
      if (g.carrier) {
        EXPECT_NE(g.object, kNoObject);
      }
    }
    EXPECT_EQ(store.sh_degree(), 1);
  }
}

TEST(SyntheticScene, ConvergedGaussiansLieOnTheSurfaceFlatAndNormalAligned) {
  SceneStore store;
  auto cfg = small(2);
  auto scene = make(cfg);
  test::produce_all(scene, store);
  const std::uint32_t converged_support = 1 + 3 * std::uint32_t(cfg.converge_epochs);
  std::size_t converged = 0;
  for (const Gaussian& g : store.gaussians()) {
    if (g.carrier || g.support != converged_support) continue;
    ++converged;
    ASSERT_LT(scene.distance_to_surface(g.position), 1e-4f) << "Gaussian " << to_underlying(g.id);
    // One log-scale much smaller: flattened along the surface.
    const float smallest = std::min(g.log_scale.x, std::min(g.log_scale.y, g.log_scale.z));
    const float largest = std::max(g.log_scale.x, std::max(g.log_scale.y, g.log_scale.z));
    ASSERT_GT(largest - smallest, std::log(5.0f));
    ASSERT_NEAR(glm::length(g.rotation), 1.0f, 1e-5f);
    const glm::vec3 c = g.sh_dc * 0.28209479f + 0.5f;
    ASSERT_TRUE(glm::all(glm::greaterThanEqual(c, glm::vec3(-1e-5f))) && glm::all(glm::lessThanEqual(c, glm::vec3(1.0001f))));
  }
  EXPECT_GT(converged, store.appearance_count() / 2);
  // The fully observed room holds about target_gaussians appearance Gaussians.
  EXPECT_LE(store.appearance_count(), cfg.target_gaussians * 105 / 100);
  EXPECT_GT(store.appearance_count(), cfg.target_gaussians * 95 / 100);
}

TEST(SyntheticScene, GaussiansCoverWhatTheLastCamerasSeeWithoutHoles) {
  SceneStore store;
  auto cfg = small(0);
  auto scene = make(cfg);
  test::produce_all(scene, store);
  // Spatial hash of the Gaussians, cells of 10 cm.
  const float cell = 0.1f;
  const auto key = [&](const glm::vec3& p) {
    const glm::ivec3 c = glm::ivec3(glm::floor(p / cell));
    return (std::int64_t(c.x) * 73856093) ^ (std::int64_t(c.y) * 19349663) ^ (std::int64_t(c.z) * 83492791);
  };
  std::unordered_map<std::int64_t, std::vector<const Gaussian*>> grid;
  for (const Gaussian& g : store.gaussians())
    if (!g.carrier) grid[key(g.position)].push_back(&g);
  const Camera cam = scene.cameras_of_epoch(cfg.epochs - 1).back();
  const GroundTruthImage gt = scene.render_ground_truth(cam);
  std::size_t points = 0, covered = 0;
  for (std::uint32_t y = 0; y < cam.height; y += 3)
    for (std::uint32_t x = 0; x < cam.width; x += 3) {
      const float d = gt.depth[std::size_t(y) * cam.width + x];
      ASSERT_GT(d, 0.0f) << "closed room: every pixel hits a surface";
      const glm::vec3 p = world_point(cam, x, y, d);
      ++points;
      bool ok = false;
      for (int dx = -1; dx <= 1 && !ok; ++dx)
        for (int dy = -1; dy <= 1 && !ok; ++dy)
          for (int dz = -1; dz <= 1 && !ok; ++dz) {
            auto it = grid.find(key(p + cell * glm::vec3(dx, dy, dz)));
            if (it == grid.end()) continue;
            for (const Gaussian* g : it->second) {
              // Within 1.5 tangential sigmas of a Gaussian centre counts as covered.
              const float sigma = std::exp(std::max(g->log_scale.x, g->log_scale.y));
              if (glm::length(g->position - p) < 1.5f * sigma + 1e-3f) {
                ok = true;
                break;
              }
            }
          }
      covered += ok;
    }
  EXPECT_GE(double(covered), 0.99 * double(points)) << covered << " of " << points << " visible points covered";
}

TEST(SyntheticScene, GaussiansAppearWhereCamerasLookedAndConverge) {
  SceneStore store;
  auto cfg = small(3);
  cfg.prune_fraction = 0.0f;
  auto scene = make(cfg);
  ASSERT_TRUE(scene.produce(store).ok());
  const std::size_t first = store.appearance_count();
  // Track the first epoch's Gaussians: they converge (closer to the surface, more opaque,
  // more support) and are exactly on the surface from age converge_epochs on.
  std::vector<GaussianId> ids;
  double dist0 = 0.0, opacity0 = 0.0;
  for (const Gaussian& g : store.gaussians())
    if (!g.carrier) {
      ids.push_back(g.id);
      dist0 += scene.distance_to_surface(g.position);
      opacity0 += g.opacity_logit;
    }
  double prev_dist = dist0, prev_opacity = opacity0;
  for (int e = 1; e <= cfg.converge_epochs; ++e) {
    ASSERT_TRUE(scene.produce(store).ok());
    double dist = 0.0, opacity = 0.0;
    for (GaussianId id : ids) {
      const Gaussian* g = store.find(id);
      ASSERT_NE(g, nullptr) << "pruning is off, yet a Gaussian vanished";
      dist += scene.distance_to_surface(g->position);
      opacity += g->opacity_logit;
    }
    EXPECT_LT(dist, prev_dist) << "epoch " << e;
    EXPECT_GT(opacity, prev_opacity) << "epoch " << e;
    prev_dist = dist;
    prev_opacity = opacity;
  }
  EXPECT_LT(prev_dist / double(ids.size()), 1e-5);
  EXPECT_LT(first, store.appearance_count()) << "later cameras should reveal more of the room";
  // A converged Gaussian is not modified any more.
  ASSERT_TRUE(scene.produce(store).ok());
  const EpochChanges* c = store.changes(store.epoch());
  ASSERT_NE(c, nullptr);
  std::set<GaussianId> modified(c->modified.begin(), c->modified.end());
  for (GaussianId id : ids) EXPECT_EQ(modified.count(id), 0u);
}

TEST(SyntheticScene, PrunedGaussiansAreReplacedWithFreshIds) {
  SceneStore store;
  auto cfg = small(0);
  cfg.prune_fraction = 0.05f;
  cfg.converge_epochs = 2;
  auto scene = make(cfg);
  std::uint64_t max_id = 0;
  std::size_t removed_total = 0;
  while (!scene.finished()) {
    ASSERT_TRUE(scene.produce(store).ok());
    const EpochChanges* c = store.changes(store.epoch());
    ASSERT_NE(c, nullptr);
    for (GaussianId id : c->inserted) EXPECT_GT(to_underlying(id), max_id) << "an id was reused";
    for (GaussianId id : c->inserted) max_id = std::max(max_id, to_underlying(id));
    removed_total += c->removed.size();
    EXPECT_LE(c->removed.size(), store.appearance_count() / 10);
  }
  EXPECT_GT(removed_total, 0u);
}

TEST(SyntheticScene, GroundTruthDepthIsExact) {
  auto scene = make(small(0));
  // Straight down onto free floor from 2 m: every floor pixel has z depth exactly 2.
  Camera cam;
  cam.width = 64;
  cam.height = 48;
  cam.fx = cam.fy = 60.0;
  cam.cx = 32.0;
  cam.cy = 24.0;
  // Camera axes in world: x right = +x, y down = +z (image "down" along +z), z forward = -y.
  glm::dmat4 m(0.0);
  m[0][0] = 1.0;   // row 0 (x_c) = (1, 0, 0)
  m[2][1] = 1.0;   // row 1 (y_c) = (0, 0, 1)
  m[1][2] = -1.0;  // row 2 (z_c) = (0, -1, 0)
  const glm::dvec3 eye(-2.0, 2.0, 0.0);
  m[3][0] = -eye.x;
  m[3][1] = -eye.z;
  m[3][2] = eye.y;
  m[3][3] = 1.0;
  cam.world_to_camera = m;
  const GroundTruthImage gt = scene.render_ground_truth(cam);
  ASSERT_EQ(gt.depth.size(), 64u * 48u);
  ASSERT_EQ(gt.colour.pixels.size(), 64u * 48u * 4u);
  EXPECT_FLOAT_EQ(gt.depth[24 * 64 + 32], 2.0f);
  EXPECT_EQ(gt.colour.pixels[(24 * 64 + 32) * 4 + 3], 255);
  // Every pixel of a trajectory camera back-projects onto an analytic surface.
  const Camera tc = scene.trajectory()[3];
  const GroundTruthImage t = scene.render_ground_truth(tc);
  for (std::uint32_t y = 0; y < tc.height; y += 2)
    for (std::uint32_t x = 0; x < tc.width; x += 2) {
      const float d = t.depth[std::size_t(y) * tc.width + x];
      ASSERT_GT(d, 0.1f);
      ASSERT_LT(scene.distance_to_surface(world_point(tc, x, y, d)), 2e-4f * d) << x << "," << y;
    }
}

// The ground truth's per-pixel object ids: every labelled pixel back-projects into the
// analytic bounds of the object it names, and the trajectory sees most objects.
TEST(SyntheticScene, GroundTruthNamesTheObjectHit) {
  auto scene = make(small(2));
  std::unordered_map<std::int32_t, const SyntheticObjectInfo*> by_id;
  for (const SyntheticObjectInfo& o : scene.objects()) by_id[to_underlying(o.id)] = &o;
  std::set<std::int32_t> seen;
  for (std::size_t k = 0; k < scene.trajectory().size(); k += 3) {
    const Camera& cam = scene.trajectory()[k];
    const GroundTruthImage gt = scene.render_ground_truth(cam);
    ASSERT_EQ(gt.object.size(), gt.depth.size());
    for (std::uint32_t y = 0; y < cam.height; y += 2)
      for (std::uint32_t x = 0; x < cam.width; x += 2) {
        const std::size_t px = std::size_t(y) * cam.width + x;
        if (gt.object[px] == kNoObject) continue;
        ASSERT_GT(gt.depth[px], 0.0f);
        const auto it = by_id.find(to_underlying(gt.object[px]));
        ASSERT_NE(it, by_id.end()) << "pixel " << x << "," << y << " names an unknown object";
        const glm::vec3 p = world_point(cam, x, y, gt.depth[px]);
        const glm::vec3 lo = it->second->extent_min - glm::vec3(0.01f), hi = it->second->extent_max + glm::vec3(0.01f);
        ASSERT_TRUE(glm::all(glm::greaterThanEqual(p, lo)) && glm::all(glm::lessThanEqual(p, hi)))
            << it->second->label << " at pixel " << x << "," << y;
        seen.insert(to_underlying(gt.object[px]));
      }
  }
  EXPECT_GE(seen.size() * 2, scene.objects().size()) << "the trajectory sees most objects";
}

TEST(SyntheticScene, TrajectoryAndMesh) {
  auto cfg = small(1);
  auto scene = make(cfg);
  ASSERT_EQ(scene.trajectory().size(), std::size_t(cfg.epochs * cfg.cameras_per_epoch));
  EXPECT_EQ(scene.cameras_of_epoch(2).size(), std::size_t(cfg.cameras_per_epoch));
  EXPECT_TRUE(scene.cameras_of_epoch(cfg.epochs).empty());
  for (const Camera& cam : scene.trajectory()) {
    const glm::dmat3 r(cam.world_to_camera);
    const glm::vec3 eye(-glm::transpose(r) * glm::dvec3(cam.world_to_camera[3]));
    EXPECT_TRUE(glm::all(glm::greaterThan(eye, scene.room_min())) && glm::all(glm::lessThan(eye, scene.room_max())));
    EXPECT_GT(scene.distance_to_surface(eye), 0.2f) << "camera too close to a surface";
  }
  const TriangleMesh mesh = scene.surface_mesh();
  ASSERT_EQ(mesh.colors.size(), mesh.positions.size());
  ASSERT_EQ(mesh.indices.size() % 3, 0u);
  ASSERT_GT(mesh.indices.size(), 300u);
  for (std::uint32_t i : mesh.indices) ASSERT_LT(i, mesh.positions.size());
  for (std::size_t i = 0; i < mesh.positions.size(); i += 7) ASSERT_LT(scene.distance_to_surface(mesh.positions[i]), 1e-4f);
  SceneStore store;
  test::produce_all(scene, store);
  EXPECT_FALSE(scene.produce(store).ok()) << "produce past the last epoch";
}

}  // namespace
}  // namespace gauss
