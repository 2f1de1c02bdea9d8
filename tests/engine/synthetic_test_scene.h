#pragma once
// The small synthetic scene the engine tests share: 160 x 120 frames at 120 px focal
// length, so producing every epoch takes well under a second.
#include <cstddef>

#include <gtest/gtest.h>

#include "gauss/engine/scene_store.h"
#include "gauss/engine/synthetic_scene.h"

namespace gauss::test {

inline SyntheticSceneConfig small_synthetic_config(std::size_t gaussians, int epochs) {
  SyntheticSceneConfig c;
  c.target_gaussians = gaussians;
  c.epochs = epochs;
  c.image_width = 160;
  c.image_height = 120;
  c.focal_px = 120.0;
  return c;
}

// Produces every remaining epoch into `store`; a fatal failure stops at the first error
// (wrap the call in ASSERT_NO_FATAL_FAILURE to stop the test too).
inline void produce_all(SyntheticScene& scene, SceneStore& store) {
  while (!scene.finished()) ASSERT_TRUE(scene.produce(store).ok());
}

}  // namespace gauss::test
