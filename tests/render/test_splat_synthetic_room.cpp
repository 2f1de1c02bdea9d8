// The embedded synthetic room (the demo's default scene) through the GPU renderer:
// against the CPU reference and its golden image, host and client renderers alike.
#include <gtest/gtest.h>

#include "gauss/engine/scene_store.h"
#include "gauss/engine/synthetic_scene.h"
#include "gauss/render/splat_renderer.h"
#include "golden.h"
#include "splat_test_util.h"
#include "vk_test.h"

namespace gauss::test {
namespace {

class SplatSyntheticRoom : public VkTest {};

// A 10k-Gaussian room after all its epochs, seen from high in a corner.
struct Room {
  std::vector<Gaussian> gaussians;  // appearance Gaussians (carriers are never drawn)
  int sh_degree{0};
  Camera camera;
};

Room make_room() {
  SyntheticSceneConfig sc;
  sc.target_gaussians = 10000;
  auto scene = SyntheticScene::create(sc);
  EXPECT_TRUE(scene) << scene.message();
  if (!scene) return {};  // an empty room fails the size assertion below
  SceneStore store;
  while (!scene->finished()) {
    const Status st = scene->produce(store);
    EXPECT_TRUE(st) << st.message();
    if (!st) return {};  // a failing produce() would otherwise never finish
  }
  Room room;
  room.sh_degree = store.sh_degree();
  for (const Gaussian& g : store.gaussians())
    if (!g.carrier) room.gaussians.push_back(g);
  room.camera = scene->overview_camera(320, 240);
  return room;
}

TEST_F(SplatSyntheticRoom, MatchesReferenceAndGolden) {
  const Room room = make_room();
  ASSERT_GT(room.gaussians.size(), 9000u);
  auto r = render::SplatRenderer::create(
      context(), {.capacity = std::uint32_t(room.gaussians.size()), .sh_degree = room.sh_degree, .max_width = 320,
                  .max_height = 240});
  ASSERT_TRUE(r) << r.message();
  ASSERT_TRUE((*r)->write_slots(0, room.gaussians));
  auto stats = (*r)->render(room.camera);
  ASSERT_TRUE(stats) << stats.message();
  EXPECT_FALSE(stats->pair_overflow);
  auto gpu = (*r)->read_image();
  ASSERT_TRUE(gpu) << gpu.message();

  auto ref = render::render_reference(room.gaussians, {}, room.sh_degree, room.camera, {});
  ASSERT_TRUE(ref) << ref.message();
  EXPECT_TRUE(close_to_reference(ref->rgba8, *gpu, "splat_synthetic_room"));
  EXPECT_GOLDEN(context(), *gpu, "splat_synthetic_room", ref->rgba8);

  // The same slots and camera on a second renderer (the host's "server render" and
  // the client's) give the same bytes.
  auto other = render::SplatRenderer::create(
      context(), {.capacity = std::uint32_t(room.gaussians.size()), .sh_degree = room.sh_degree, .max_width = 320,
                  .max_height = 240});
  ASSERT_TRUE(other) << other.message();
  ASSERT_TRUE((*other)->write_slots(0, room.gaussians));
  ASSERT_TRUE((*other)->render(room.camera));
  auto again = (*other)->read_image();
  ASSERT_TRUE(again);
  EXPECT_EQ(again->pixels, gpu->pixels);
}

}  // namespace
}  // namespace gauss::test
