#pragma once
// The small host-side world the HostSession tests share: a 2000-Gaussian synthetic room
// produced over `epochs` epochs (then, when `chunks` are given, one surface epoch holding
// them), with codec parameters over the room; and a one-triangle surface chunk.
#include <cstdint>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/engine/codec.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/synthetic_scene.h"

namespace gauss::test {

struct HostWorld {
  explicit HostWorld(int epochs = 2, std::vector<SurfaceChunk> chunks = {}) {
    SyntheticSceneConfig c;
    c.target_gaussians = 2000;
    c.epochs = epochs;
    auto s = SyntheticScene::create(c);
    EXPECT_TRUE(s.ok()) << s.message();
    while (!s->finished()) EXPECT_TRUE(s->produce(store).ok());
    if (!chunks.empty()) {
      EXPECT_TRUE(store.begin_next_epoch().ok());
      for (auto& ch : chunks) EXPECT_TRUE(store.set_surface_chunk(std::move(ch)).ok());
      EXPECT_TRUE(store.commit_epoch().ok());
    }
    params.box.min = s->room_min() - glm::vec3(0.5f);
    params.box.max = s->room_max() + glm::vec3(0.5f);
    params.sh_degree = 1;
  }
  SceneStore store;
  CodecParams params;
};

inline SurfaceChunk triangle_chunk(std::uint32_t id, float x) {
  SurfaceChunk c;
  c.chunk_id = id;
  c.mesh.positions = {{x, 0, 0}, {x + 1, 0, 0}, {x, 1, 0}};
  c.mesh.colors = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  c.mesh.indices = {0, 1, 2};
  return c;
}

}  // namespace gauss::test
