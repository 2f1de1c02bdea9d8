// Picking an object with a controller ray: the nearest Gaussian within two sigmas wins,
// unlabelled content in front hides what is behind it, transparent and degenerate
// Gaussians and bad rays are handled.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "gauss/client/ray_pick.h"

namespace gauss::client {
namespace {

Gaussian blob(glm::vec3 at, float sigma, ObjectId object, float opacity = 0.9f) {
  Gaussian g;
  g.position = at;
  g.log_scale = glm::vec3(std::log(sigma));
  g.opacity_logit = std::log(opacity / (1.0f - opacity));
  g.object = object;
  return g;
}

SlotTable table_of(std::initializer_list<Gaussian> gs) {
  auto t = SlotTable::create(16);
  EXPECT_TRUE(t);
  std::uint64_t id = 1;
  for (const Gaussian& g : gs) EXPECT_TRUE(t->insert(GaussianId{id++}, g));
  return std::move(*t);
}

TEST(RayPick, TheNearestGaussianWithinTwoSigmasIsPicked) {
  const SlotTable t = table_of({blob({0, 0, 4}, 0.1f, ObjectId{2}), blob({0, 0, 2}, 0.1f, ObjectId{1}),
                                blob({1, 0, 1}, 0.1f, kNoObject)});
  auto hit = pick(t, glm::dvec3(0.0), glm::dvec3(0, 0, 3));  // direction need not be unit
  ASSERT_TRUE(hit);
  EXPECT_EQ(hit->object, ObjectId{1});
  EXPECT_NEAR(hit->distance, 2.0, 1e-9);
  // 0.15 m to the side: 1.5 sigmas from the blob's centre, still a hit; 0.25 m is not.
  EXPECT_EQ(pick(t, glm::dvec3(0.15, 0, 0), glm::dvec3(0, 0, 1))->object, ObjectId{1});
  EXPECT_FALSE(pick(t, glm::dvec3(0.25, 0, 0), glm::dvec3(0, 0, 1)));
  // Pointing away: nothing behind the controller counts.
  EXPECT_FALSE(pick(t, glm::dvec3(0.0), glm::dvec3(0, 0, -1)));
}

TEST(RayPick, UnlabelledContentInFrontHidesTheObjectBehind) {
  const SlotTable t = table_of({blob({0, 0, 3}, 0.1f, ObjectId{5}), blob({0, 0, 1}, 0.3f, kNoObject)});
  auto hit = pick(t, glm::dvec3(0.0), glm::dvec3(0, 0, 1));
  ASSERT_TRUE(hit);
  EXPECT_EQ(hit->object, kNoObject);
}

TEST(RayPick, AFlatGaussianIsHitAcrossItsPlaneOnly) {
  Gaussian disc = blob({0, 0, 2}, 0.2f, ObjectId{3});
  disc.log_scale.z = std::log(0.0f);  // -inf: a degenerate axis, treated as 0.1 mm
  const SlotTable t = table_of({disc});
  EXPECT_EQ(pick(t, glm::dvec3(0.3, 0, 0), glm::dvec3(0, 0, 1))->object, ObjectId{3});  // through the disc
  EXPECT_FALSE(pick(t, glm::dvec3(-1, 0, 2.01), glm::dvec3(1, 0, 0)));  // along it, 1 cm off its plane
}

TEST(RayPick, TransparentGaussiansAndBadRaysPickNothing) {
  const SlotTable t = table_of({blob({0, 0, 2}, 0.1f, ObjectId{1}, 0.2f)});
  EXPECT_FALSE(pick(t, glm::dvec3(0.0), glm::dvec3(0, 0, 1)));
  const SlotTable u = table_of({blob({0, 0, 2}, 0.1f, ObjectId{1})});
  EXPECT_FALSE(pick(u, glm::dvec3(0.0), glm::dvec3(0.0)));
  EXPECT_FALSE(pick(u, glm::dvec3(0.0), glm::dvec3(0, std::nan(""), 1)));
  EXPECT_FALSE(pick(u, glm::dvec3(std::numeric_limits<double>::infinity(), 0, 0), glm::dvec3(0, 0, 1)));
}

}  // namespace
}  // namespace gauss::client
