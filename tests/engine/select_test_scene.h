#pragma once
// Random scenes for the query / selector / differ tests: Gaussians in a 10 m box with
// objects of a few classes, some carriers, and helpers to evolve them epoch by epoch.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/engine/scene_store.h"
#include "gauss/engine/selector.h"

namespace gauss::test {

inline const char* const kTestLabels[] = {"chair", "Table", "plant", "chair", "keyboard", "chair", "shelf"};
inline constexpr int kTestObjects = 7;  // object ids 0..6; labels above

inline Gaussian random_test_gaussian(std::mt19937_64& rng, GaussianId id) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Gaussian g;
  g.id = id;
  // Braced lists: their elements are evaluated in order (function arguments are not, so
  // glm::vec3(u(rng), u(rng), ...) gave GCC and clang different scenes).
  g.position = glm::vec3{u(rng) * 10.0f - 5.0f, u(rng) * 3.0f, u(rng) * 10.0f - 5.0f};
  g.log_scale = glm::vec3{-5.0f + 2.5f * u(rng), -5.0f + 2.5f * u(rng), -6.0f + 2.0f * u(rng)};
  g.rotation = glm::normalize(glm::vec4{u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f} + 0.01f);
  g.opacity_logit = 6.0f * u(rng) - 3.0f;
  g.sh_dc = glm::vec3{u(rng) * 3.0f - 1.5f, u(rng) * 3.0f - 1.5f, u(rng) * 3.0f - 1.5f};
  g.support = static_cast<std::uint32_t>(rng() % 200);
  const int o = static_cast<int>(rng() % 12) - 1;  // about 40 % unlabelled
  g.object = o < kTestObjects && o >= 0 ? ObjectId{o} : kNoObject;
  g.carrier = (rng() % 100) == 0;
  return g;
}

// Epoch 1 of a scene with n Gaussians.
inline void fill_test_scene(SceneStore& store, std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  ASSERT_TRUE(store.begin_next_epoch().ok());
  for (int o = 0; o < kTestObjects; ++o) ASSERT_TRUE(store.set_object(ObjectId{o}, kTestLabels[o]).ok());
  for (std::size_t i = 0; i < n; ++i) ASSERT_TRUE(store.insert(random_test_gaussian(rng, store.allocate_id())).ok());
  ASSERT_TRUE(store.commit_epoch().ok());
}

// One evolving epoch: modifies, removes and inserts a few percent.
inline void evolve_test_scene(SceneStore& store, std::mt19937_64& rng, double fraction) {
  std::vector<Gaussian> all(store.gaussians().begin(), store.gaussians().end());
  ASSERT_TRUE(store.begin_next_epoch().ok());
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (const Gaussian& g : all) {
    const float r = u(rng);
    if (r < fraction) {
      Gaussian m = g;
      m.position += glm::vec3(0.01f * (u(rng) - 0.5f), 0.0f, 0.0f);
      m.sh_dc.x += 0.2f * (u(rng) - 0.5f);
      ASSERT_TRUE(store.modify(m).ok());
    } else if (r < 2 * fraction) {
      ASSERT_TRUE(store.remove(g.id).ok());
    }
  }
  const auto inserts = static_cast<std::size_t>(fraction * static_cast<double>(all.size()));
  for (std::size_t i = 0; i < inserts; ++i) {
    ASSERT_TRUE(store.insert(random_test_gaussian(rng, store.allocate_id())).ok());
  }
  ASSERT_TRUE(store.commit_epoch().ok());
}

// A head pose inside the box looking in a random horizontal direction.
inline ClientPose random_test_pose(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  ClientPose p;
  p.position = glm::dvec3{u(rng) * 6.0 - 3.0, 1.6, u(rng) * 6.0 - 3.0};
  const double yaw = u(rng) * 6.283185307179586;
  const double pitch = (u(rng) - 0.5) * 0.6;
  p.orientation = glm::angleAxis(yaw, glm::dvec3(0, 1, 0)) * glm::angleAxis(pitch, glm::dvec3(1, 0, 0));
  p.tan_half_fov_x = 1.0;
  p.tan_half_fov_y = 0.9;
  return p;
}

}  // namespace gauss::test
