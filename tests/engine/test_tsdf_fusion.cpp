#include <cmath>
#include <map>
#include <set>
#include <tuple>

#include <gtest/gtest.h>

#include "gauss/engine/tsdf.h"
#include "tsdf_test_scene.h"

namespace gauss {
namespace {

using test::AnalyticRoom;

TsdfVolume make_volume(float voxel, std::uint32_t max_blocks = 200000) {
  TsdfConfig cfg;
  cfg.voxel_size = voxel;
  cfg.max_blocks = max_blocks;
  auto v = TsdfVolume::create(cfg);
  EXPECT_TRUE(v) << v.message();
  return std::move(v).value();
}

void fuse_views(TsdfVolume& vol, const AnalyticRoom& room, int views, std::uint32_t w, std::uint32_t h) {
  for (int k = 0; k < views; ++k) {
    const double a = 2.0 * 3.14159265358979 * k / views;
    const glm::dvec3 eye(1.2 * std::cos(a), 0.3, 1.2 * std::sin(a));
    ASSERT_TRUE(vol.integrate(room.frame(eye, room.sphere_centre, w, h, Epoch(k + 1))));
  }
}

TEST(TsdfFusion, MeshLiesOnTheAnalyticSurfaceWithinHalfAVoxel) {
  const AnalyticRoom room;
  const float voxel = 0.04f;
  TsdfVolume vol = make_volume(voxel);
  fuse_views(vol, room, 8, 160, 120);
  const TriangleMesh mesh = vol.extract_all();
  ASSERT_GT(mesh.indices.size(), 3000u);
  double sum = 0.0;
  for (const auto& p : mesh.positions) sum += room.distance(glm::dvec3(p));
  const double mean = sum / double(mesh.positions.size());
  RecordProperty("mean_distance_voxels", std::to_string(mean / voxel));
  EXPECT_LE(mean, 0.5 * voxel) << "mean vertex distance " << mean << " m";
}

TEST(TsdfFusion, ChunksMeetWithoutCracksAndWindingIsConsistent) {
  // Watertight check over the whole sphere: merge chunk vertices by exact position;
  // every undirected edge of the sphere must then be used by exactly two triangles,
  // once in each direction.
  AnalyticRoom room;
  TsdfVolume vol = make_volume(0.04f);
  fuse_views(vol, room, 12, 160, 120);
  std::vector<SurfaceEdit> edits = vol.extract_changed();
  ASSERT_GT(edits.size(), 4u);
  std::map<std::tuple<float, float, float>, int> id_of;
  std::map<std::pair<int, int>, int> directed;
  for (const auto& e : edits) {
    std::vector<int> ids;
    for (const auto& p : e.mesh.positions) ids.push_back(id_of.emplace(std::make_tuple(p.x, p.y, p.z), int(id_of.size())).first->second);
    for (std::size_t t = 0; t < e.mesh.indices.size(); t += 3) {
      const glm::vec3 c = (e.mesh.positions[e.mesh.indices[t]] + e.mesh.positions[e.mesh.indices[t + 1]] +
                           e.mesh.positions[e.mesh.indices[t + 2]]) / 3.0f;
      if (glm::length(glm::dvec3(c) - room.sphere_centre) > room.sphere_radius + 0.1) continue;  // sphere only
      for (int k = 0; k < 3; ++k) ++directed[{ids[e.mesh.indices[t + k]], ids[e.mesh.indices[t + (k + 1) % 3]]}];
    }
  }
  std::size_t interior = 0, bad = 0;
  for (const auto& [edge, count] : directed) {
    auto rev = directed.find({edge.second, edge.first});
    // Edges at the sphere selection's border have no partner; everything else must pair.
    if (rev == directed.end()) continue;
    ++interior;
    if (count != 1 || rev->second != 1) ++bad;
  }
  EXPECT_GT(interior, 1000u);
  EXPECT_EQ(bad, 0u);
  // The border of the selected region is small compared with its interior: a crack
  // between chunks would leave a long unpaired seam.
  std::size_t unpaired = 0;
  for (const auto& [edge, count] : directed) unpaired += directed.count({edge.second, edge.first}) == 0;
  EXPECT_LT(unpaired, interior / 10) << "unpaired edges " << unpaired << " vs paired " << interior;
}

TEST(TsdfFusion, NormalsPointIntoFreeSpace) {
  AnalyticRoom room;
  TsdfVolume vol = make_volume(0.04f);
  fuse_views(vol, room, 8, 160, 120);
  const TriangleMesh mesh = vol.extract_all();
  std::size_t outward = 0, total = 0;
  for (std::size_t t = 0; t < mesh.indices.size(); t += 3) {
    const glm::dvec3 a(mesh.positions[mesh.indices[t]]), b(mesh.positions[mesh.indices[t + 1]]),
        c(mesh.positions[mesh.indices[t + 2]]);
    const glm::dvec3 centre = (a + b + c) / 3.0;
    if (std::abs(glm::length(centre - room.sphere_centre) - room.sphere_radius) > 0.05) continue;
    const glm::dvec3 n = glm::cross(b - a, c - a);
    if (glm::length(n) < 1e-12) continue;
    ++total;
    outward += glm::dot(n, centre - room.sphere_centre) > 0;
  }
  ASSERT_GT(total, 500u);
  EXPECT_EQ(outward, total);
}

TEST(TsdfFusion, IncrementalExtractionReportsOnlyChangedChunksWithTheirEpoch) {
  AnalyticRoom room;
  TsdfVolume vol = make_volume(0.05f);
  ASSERT_TRUE(vol.integrate(room.frame({0, 0, 1.5}, {0, 0, -2}, 96, 72, Epoch(1))));
  auto first = vol.extract_changed();
  ASSERT_FALSE(first.empty());
  for (const auto& e : first) {
    EXPECT_EQ(e.kind, SurfaceEditKind::Add);
    EXPECT_EQ(e.epoch, Epoch(1));
    EXPECT_FALSE(e.mesh.indices.empty());
    EXPECT_EQ(e.mesh.colors.size(), e.mesh.positions.size());
  }
  EXPECT_TRUE(vol.extract_changed().empty()) << "nothing changed since the last extraction";
  // Looking the other way touches other chunks: the first view's chunks are not re-sent
  // unless the new frame wrote into their blocks.
  ASSERT_TRUE(vol.integrate(room.frame({0, 0, -1.5}, {0, 0, 2}, 96, 72, Epoch(2))));
  auto second = vol.extract_changed();
  ASSERT_FALSE(second.empty());
  std::set<std::uint32_t> first_ids;
  for (const auto& e : first) first_ids.insert(e.chunk_id);
  std::size_t replaced = 0;
  for (const auto& e : second) {
    EXPECT_EQ(e.epoch, Epoch(2)) << "a re-extracted chunk carries the newest fused epoch";
    if (e.kind == SurfaceEditKind::Replace) {
      ++replaced;
      EXPECT_TRUE(first_ids.count(e.chunk_id));
    }
    if (e.kind == SurfaceEditKind::Add) {
      EXPECT_FALSE(first_ids.count(e.chunk_id));
    }
  }
  EXPECT_LT(replaced, first.size()) << "an opposite view must not re-send every chunk";
}

TEST(TsdfFusion, BadFramesAreRejectedNamingTheFrameAndLeaveTheVolumeUntouched) {
  AnalyticRoom room;
  TsdfVolume vol = make_volume(0.05f);
  ASSERT_TRUE(vol.integrate(room.frame({0, 0, 1.5}, {0, 0, -2}, 64, 48, Epoch(1))));
  const TriangleMesh before = vol.extract_all();
  const std::size_t blocks = vol.stats().blocks;
  (void)vol.extract_changed();

  auto expect_rejected = [&](RgbdFrame f, const std::string& fragment) {
    f.name = "bad-frame-7";
    auto st = vol.integrate(f);
    ASSERT_FALSE(st) << fragment;
    EXPECT_NE(st.message().find("bad-frame-7"), std::string::npos) << st.message();
    EXPECT_NE(st.message().find(fragment), std::string::npos) << st.message();
  };
  const RgbdFrame good = room.frame({0.5, 0, 0}, {-2, 0, 0}, 64, 48, Epoch(2));
  RgbdFrame f = good;
  f.depth.pop_back();
  expect_rejected(f, "depth has");
  f = good;
  f.colour.width = 10;
  f.colour.height = 10;
  f.colour.pixels.assign(400, 0);
  expect_rejected(f, "colour image is 10x10");
  f = good;
  f.camera_to_world[3][0] = std::nan("");
  expect_rejected(f, "non-finite");
  f = good;
  f.camera_to_world = glm::dmat4(0.0);
  f.camera_to_world[3][3] = 1.0;
  expect_rejected(f, "not orthonormal");
  f = good;
  f.camera_to_world[0][0] = 1.1;
  expect_rejected(f, "not orthonormal");
  f = good;
  f.depth[100] = -0.5f;
  expect_rejected(f, "row 1, column 36");
  f = good;
  f.depth[5] = std::numeric_limits<float>::infinity();
  expect_rejected(f, "absurd");
  f = good;
  f.fx = 0;
  expect_rejected(f, "intrinsics");
  f = good;
  f.width = 0;
  expect_rejected(f, "size is zero");

  EXPECT_EQ(vol.stats().blocks, blocks);
  EXPECT_TRUE(vol.extract_changed().empty());
  const TriangleMesh after = vol.extract_all();
  EXPECT_EQ(after.positions, before.positions);
  EXPECT_EQ(after.indices, before.indices);
  EXPECT_EQ(vol.stats().frames_rejected, 9u);
}

TEST(TsdfFusion, MemoryBoundRefusesTheFrameInsteadOfGrowing) {
  AnalyticRoom room;
  TsdfVolume vol = make_volume(0.02f, 50);
  auto st = vol.integrate(room.frame({0, 0, 1.5}, {0, 0, -2}, 64, 48, Epoch(1)));
  ASSERT_FALSE(st);
  EXPECT_NE(st.message().find("max_blocks"), std::string::npos) << st.message();
  EXPECT_EQ(vol.stats().blocks, 0u);
}

TEST(TsdfFusion, RejectsBadConfig) {
  TsdfConfig c;
  c.voxel_size = 0.0f;
  EXPECT_FALSE(TsdfVolume::create(c));
  c = {};
  c.voxel_size = std::nanf("");
  EXPECT_FALSE(TsdfVolume::create(c));
  c = {};
  c.max_depth = c.min_depth;
  EXPECT_FALSE(TsdfVolume::create(c));
  c = {};
  c.chunk_blocks = 0;
  EXPECT_FALSE(TsdfVolume::create(c));
}

TEST(TsdfFusion, SampleGivesSignedDistanceNearTheSurface) {
  AnalyticRoom room;
  TsdfVolume vol = make_volume(0.04f);
  fuse_views(vol, room, 8, 160, 120);
  // Points just outside the sphere are in free space (positive), just inside negative.
  // Only the sign is exact: a projective TSDF measures along the view ray, so its
  // magnitude overestimates the Euclidean distance on oblique views.
  const glm::dvec3 dir = glm::normalize(glm::dvec3(1.0, 0.25, 0.0));
  float w = 0;
  const float outside = vol.sample(glm::vec3(room.sphere_centre + dir * (room.sphere_radius + 0.03)), &w);
  EXPECT_GT(w, 0.0f);
  EXPECT_GT(outside, 0.0f);
  const float inside = vol.sample(glm::vec3(room.sphere_centre + dir * (room.sphere_radius - 0.03)), &w);
  EXPECT_GT(w, 0.0f);
  EXPECT_LT(inside, 0.0f);
  vol.sample(glm::vec3(50.0f, 0.0f, 0.0f), &w);
  EXPECT_EQ(w, 0.0f);
}

}  // namespace
}  // namespace gauss
