// The embedded synthetic scenes get their surface the way a real capture does: their
// ground-truth depth frames are fused, and the chunks land in the scene store.
#include <gtest/gtest.h>

#include "gauss/engine/scene_store.h"
#include "gauss/engine/synthetic_scene.h"
#include "gauss/engine/tsdf.h"
#include "synthetic_test_scene.h"

namespace gauss {
namespace {

TEST(TsdfSynthetic, FusedRoomLiesOnTheAnalyticSurfaceWithinHalfAVoxel) {
  const SyntheticSceneConfig sc = test::small_synthetic_config(2000, 4);
  auto scene = SyntheticScene::create(sc);
  ASSERT_TRUE(scene) << scene.message();
  TsdfConfig tc;
  tc.voxel_size = 0.04f;
  auto vol = TsdfVolume::create(tc);
  ASSERT_TRUE(vol);
  SceneStore store;
  std::size_t chunks_sent = 0;
  for (int e = 0; e < sc.epochs; ++e) {
    ASSERT_TRUE(scene->produce(store));
    const Epoch epoch = store.epoch();
    for (const Camera& cam : scene->cameras_of_epoch(e))
      ASSERT_TRUE(vol->integrate(synthetic_rgbd_frame(*scene, cam, epoch)));
    const auto edits = vol->extract_changed();
    chunks_sent += edits.size();
    ASSERT_TRUE(store.begin_next_epoch());
    ASSERT_TRUE(apply_surface_edits(store, edits));
    ASSERT_TRUE(store.commit_epoch());
  }
  ASSERT_FALSE(store.surface_chunks().empty());
  double sum = 0.0;
  std::size_t n = 0;
  for (const auto& chunk : store.surface_chunks()) {
    EXPECT_LE(chunk.epoch, store.epoch());
    for (const auto& p : chunk.mesh.positions) {
      sum += scene->distance_to_surface(p);
      ++n;
    }
  }
  ASSERT_GT(n, 1000u);
  const double mean = sum / double(n);
  RecordProperty("mean_distance_voxels", std::to_string(mean / tc.voxel_size));
  EXPECT_LE(mean, 0.5 * tc.voxel_size) << "mean vertex distance " << mean << " m over " << n << " vertices";
  EXPECT_GE(chunks_sent, store.surface_chunks().size());
}

}  // namespace
}  // namespace gauss
