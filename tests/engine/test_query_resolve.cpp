// Semantic query resolution: class text (case-insensitive, all instances), instance id,
// counts and extents, and clear errors for unknown classes and ids.
#include <gtest/gtest.h>

#include "gauss/engine/query.h"
#include "gauss/engine/scene_store.h"
#include "select_test_scene.h"

namespace gauss {
namespace {

std::vector<SemanticObject> table() {
  std::vector<SemanticObject> t(4);
  t[0] = {ObjectId{3}, "Chair", {GaussianId{1}, GaussianId{2}}, glm::vec3(1), glm::vec3(0), glm::vec3(2), 1.0f};
  t[1] = {ObjectId{5}, "table", {GaussianId{3}}, glm::vec3(4), glm::vec3(3), glm::vec3(5), 1.0f};
  t[2] = {ObjectId{1}, "chair", {GaussianId{4}, GaussianId{5}, GaussianId{6}}, glm::vec3(-1), glm::vec3(-2),
          glm::vec3(-0.5f), 0.5f};
  t[3] = {ObjectId{9}, "chair", {}, glm::vec3(0), glm::vec3(0), glm::vec3(0), 0.0f};
  return t;
}

TEST(QueryResolve, ClassResolvesToAllInstancesCaseInsensitively) {
  const auto objects = table();
  auto r = resolve_query(SemanticQuery::for_class("  CHAIR "), objects);
  ASSERT_TRUE(r.ok()) << r.message();
  ASSERT_EQ(r->objects.size(), 3u);
  EXPECT_EQ(r->ids(), (std::vector<ObjectId>{ObjectId{1}, ObjectId{3}, ObjectId{9}}));
  EXPECT_EQ(r->gaussians, 5u);
  EXPECT_EQ(r->objects[0].gaussians, 3u);
  // Union of the extents of objects with members (the empty instance 9 adds none).
  EXPECT_EQ(r->extent_min, glm::vec3(-2));
  EXPECT_EQ(r->extent_max, glm::vec3(2));
}

TEST(QueryResolve, InstanceResolvesToOneObject) {
  const auto objects = table();
  auto r = resolve_query(SemanticQuery::for_instance(ObjectId{5}), objects);
  ASSERT_TRUE(r.ok()) << r.message();
  ASSERT_EQ(r->objects.size(), 1u);
  EXPECT_EQ(r->objects[0].label, "table");
  EXPECT_EQ(r->gaussians, 1u);
  EXPECT_EQ(r->extent_min, glm::vec3(3));
  EXPECT_EQ(r->extent_max, glm::vec3(5));
}

TEST(QueryResolve, UnknownClassOrIdIsAClearError) {
  const auto objects = table();
  auto r = resolve_query(SemanticQuery::for_class("sofa"), objects);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("unknown class"), std::string::npos) << r.message();
  EXPECT_NE(r.message().find("chair, table"), std::string::npos) << r.message();
  r = resolve_query(SemanticQuery::for_instance(ObjectId{4}), objects);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("#4"), std::string::npos) << r.message();
  EXPECT_FALSE(resolve_query(SemanticQuery::for_instance(kNoObject), objects).ok());
  EXPECT_FALSE(resolve_query(SemanticQuery::for_class("   "), objects).ok());
  EXPECT_FALSE(resolve_query(SemanticQuery::for_class("chair"), {}).ok());
}

TEST(QueryResolve, AgainstASceneStoreCountsAppearanceMembersOnly) {
  SceneStore store;
  test::fill_test_scene(store, 3000, 5);
  auto r = resolve_query(SemanticQuery::for_class("chair"), store.objects());
  ASSERT_TRUE(r.ok()) << r.message();
  EXPECT_EQ(r->ids(), (std::vector<ObjectId>{ObjectId{0}, ObjectId{3}, ObjectId{5}}));
  std::size_t expect = 0;
  for (const Gaussian& g : store.gaussians()) {
    const auto o = to_underlying(g.object);
    if (!g.carrier && (o == 0 || o == 3 || o == 5)) ++expect;
  }
  EXPECT_EQ(r->gaussians, expect);
  EXPECT_GT(expect, 0u);
}

}  // namespace
}  // namespace gauss
