// SceneStore semantics: epochs, insert/modify/remove, the change log, carriers never
// counted as appearance, object membership/centroid/extent recomputed at commit, chunks.
#include <cmath>
#include <cstdint>
#include <limits>

#include <gtest/gtest.h>

#include "gauss/engine/scene_store.h"

namespace gauss {
namespace {

Gaussian make(std::uint64_t id, glm::vec3 p, int object = -1, bool carrier = false) {
  Gaussian g;
  g.id = GaussianId{id};
  g.position = p;
  g.object = ObjectId{object};
  g.carrier = carrier;
  return g;
}

std::vector<std::uint64_t> raw(const std::vector<GaussianId>& ids) {
  std::vector<std::uint64_t> r;
  for (auto id : ids) r.push_back(to_underlying(id));
  return r;
}

TEST(SceneStore, MutationsNeedAnOpenEpochAndEpochsIncrease) {
  SceneStore s;
  EXPECT_EQ(s.epoch(), Epoch{0});
  EXPECT_FALSE(s.insert(make(1, {0, 0, 0})).ok());
  EXPECT_FALSE(s.commit_epoch().ok());
  ASSERT_TRUE(s.begin_epoch(Epoch{5}).ok());
  EXPECT_FALSE(s.begin_epoch(Epoch{6}).ok()) << "nested epoch accepted";
  ASSERT_TRUE(s.commit_epoch().ok());
  EXPECT_EQ(s.epoch(), Epoch{5});
  EXPECT_FALSE(s.begin_epoch(Epoch{5}).ok());
  EXPECT_FALSE(s.begin_epoch(Epoch{3}).ok());
  ASSERT_TRUE(s.begin_next_epoch().ok());
  ASSERT_TRUE(s.commit_epoch().ok());
  EXPECT_EQ(s.epoch(), Epoch{6});
}

// The serving path reads a large scene's Gaussians at scattered places (a diff's entering
// records, a cut's leaves): however the store grows, one way or the other, its Gaussians sit
// on the 2 MiB-aligned blocks the huge-page allocator gives (id_index.h), not where a plain
// vector's growth would put them (page-aligned plus a header, on 4 KiB pages here).
TEST(SceneStore, LargeScenesLieOnHugePageBlocksHoweverTheyGrow) {
  constexpr std::uintptr_t kHugePage = std::uintptr_t{2} << 20;
  const std::size_t n = (std::size_t{8} << 20) / sizeof(Gaussian);  // 8 MiB of Gaussians
  SceneStore grown;  // by inserts alone: push_back's doubling
  ASSERT_TRUE(grown.begin_next_epoch().ok());
  for (std::uint64_t i = 1; i <= n; ++i) ASSERT_TRUE(grown.insert(make(i, {float(i % 97), 0, 0})).ok());
  ASSERT_TRUE(grown.commit_epoch().ok());
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(grown.gaussians().data()) % kHugePage, 0u);

  SceneStore reserved;  // room asked for first, as a snapshot's apply does
  ASSERT_TRUE(reserved.reserve(n).ok());
  ASSERT_TRUE(reserved.begin_next_epoch().ok());
  for (std::uint64_t i = 1; i <= n; ++i) ASSERT_TRUE(reserved.insert(make(i, {float(i % 97), 0, 0})).ok());
  ASSERT_TRUE(reserved.commit_epoch().ok());
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(reserved.gaussians().data()) % kHugePage, 0u);
  EXPECT_EQ(reserved.gaussians()[n / 2].id, grown.gaussians()[n / 2].id);
}

TEST(SceneStore, InsertModifyRemoveAndChangeLog) {
  SceneStore s;
  ASSERT_TRUE(s.begin_next_epoch().ok());
  for (std::uint64_t i = 1; i <= 5; ++i) ASSERT_TRUE(s.insert(make(i, {float(i), 0, 0})).ok());
  ASSERT_TRUE(s.commit_epoch().ok());
  ASSERT_EQ(s.size(), 5u);
  ASSERT_NE(s.changes(Epoch{1}), nullptr);
  EXPECT_EQ(raw(s.changes(Epoch{1})->inserted), (std::vector<std::uint64_t>{1, 2, 3, 4, 5}));

  ASSERT_TRUE(s.begin_next_epoch().ok());
  Gaussian g2 = *s.find(GaussianId{2});
  g2.opacity_logit = 3.0f;
  ASSERT_TRUE(s.modify(g2).ok());
  ASSERT_TRUE(s.modify(*s.find(GaussianId{4})).ok());  // identical record: not a change
  ASSERT_TRUE(s.remove(GaussianId{3}).ok());
  EXPECT_EQ(s.find(GaussianId{3}), nullptr) << "removal not visible to find() inside the epoch";
  ASSERT_TRUE(s.insert(make(10, {9, 9, 9})).ok());
  Gaussian g10 = *s.find(GaussianId{10});
  g10.support = 7;
  ASSERT_TRUE(s.modify(g10).ok());                     // inserted + modified = inserted
  ASSERT_TRUE(s.insert(make(11, {1, 1, 1})).ok());
  ASSERT_TRUE(s.remove(GaussianId{11}).ok());          // inserted + removed = nothing
  Gaussian g5 = *s.find(GaussianId{5});
  g5.support = 2;
  ASSERT_TRUE(s.modify(g5).ok());
  ASSERT_TRUE(s.remove(GaussianId{5}).ok());           // modified + removed = removed
  ASSERT_TRUE(s.commit_epoch().ok());

  const EpochChanges* c = s.changes(Epoch{2});
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(raw(c->inserted), (std::vector<std::uint64_t>{10}));
  EXPECT_EQ(raw(c->modified), (std::vector<std::uint64_t>{2}));
  EXPECT_EQ(raw(c->removed), (std::vector<std::uint64_t>{3, 5}));
  EXPECT_EQ(s.find(GaussianId{10})->support, 7u);
  EXPECT_EQ(s.find(GaussianId{2})->opacity_logit, 3.0f);

  // Dense span: new ones were appended (1 2 3 4 5 10 11); each removal's place is filled by
  // the last Gaussian, highest place first: 11 drops, 10 fills 5's place, then 3's place.
  std::vector<std::uint64_t> order;
  for (const Gaussian& g : s.gaussians()) order.push_back(to_underlying(g.id));
  EXPECT_EQ(order, (std::vector<std::uint64_t>{1, 2, 10, 4}));
  for (const Gaussian& g : s.gaussians()) EXPECT_EQ(s.find(g.id), &g);
}

TEST(SceneStore, IdsAreNeverReusedAndErrorsNameTheId) {
  SceneStore s;
  ASSERT_TRUE(s.begin_next_epoch().ok());
  ASSERT_TRUE(s.insert(make(7, {0, 0, 0})).ok());
  auto dup = s.insert(make(7, {1, 0, 0}));
  ASSERT_FALSE(dup.ok());
  EXPECT_NE(dup.message().find("7"), std::string::npos) << dup.message();
  ASSERT_TRUE(s.remove(GaussianId{7}).ok());
  EXPECT_FALSE(s.insert(make(7, {0, 0, 0})).ok()) << "a removed id was reused";
  EXPECT_FALSE(s.remove(GaussianId{7}).ok());
  EXPECT_FALSE(s.modify(make(99, {0, 0, 0})).ok());
  EXPECT_GT(to_underlying(s.allocate_id()), 7u);
  ASSERT_TRUE(s.commit_epoch().ok());
}

TEST(SceneStore, NonFiniteAndOutOfDegreeRecordsAreRejectedWithoutLoss) {
  SceneStore s;
  ASSERT_TRUE(s.begin_next_epoch().ok());
  ASSERT_TRUE(s.insert(make(1, {1, 2, 3})).ok());
  Gaussian bad = make(2, {0, std::numeric_limits<float>::quiet_NaN(), 0});
  auto r = s.insert(bad);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("position"), std::string::npos) << r.message();
  Gaussian sh = make(3, {0, 0, 0});
  sh.sh_rest[0] = glm::vec3(0.1f);
  EXPECT_FALSE(s.insert(sh).ok()) << "SH rest accepted at degree 0";
  ASSERT_TRUE(s.set_sh_degree(1).ok());
  EXPECT_TRUE(s.insert(sh).ok());
  EXPECT_FALSE(s.set_sh_degree(0).ok()) << "degree lowered below stored coefficients";
  Gaussian m = *s.find(GaussianId{1});
  m.opacity_logit = std::numeric_limits<float>::infinity();
  EXPECT_FALSE(s.modify(m).ok());
  EXPECT_EQ(s.find(GaussianId{1})->opacity_logit, 0.0f) << "failed modify changed the record";
  EXPECT_EQ(s.find(GaussianId{1})->position, glm::vec3(1, 2, 3));
  ASSERT_TRUE(s.commit_epoch().ok());
  EXPECT_EQ(s.size(), 2u);
}

TEST(SceneStore, CarriersAreNeverAppearance) {
  SceneStore s;
  ASSERT_TRUE(s.begin_next_epoch().ok());
  ASSERT_TRUE(s.set_object(ObjectId{4}, "chair", 0.8f).ok());
  ASSERT_TRUE(s.insert(make(1, {0, 0, 0}, 4)).ok());
  ASSERT_TRUE(s.insert(make(2, {2, 0, 0}, 4)).ok());
  ASSERT_TRUE(s.insert(make(3, {100, 100, 100}, 4, /*carrier=*/true)).ok());
  ASSERT_TRUE(s.commit_epoch().ok());
  EXPECT_EQ(s.size(), 3u);
  EXPECT_EQ(s.appearance_count(), 2u);
  EXPECT_EQ(s.carrier_count(), 1u);
  const SemanticObject* o = s.find_object(ObjectId{4});
  ASSERT_NE(o, nullptr);
  EXPECT_EQ(raw(o->members), (std::vector<std::uint64_t>{1, 2}));
  EXPECT_EQ(o->extent_max, glm::vec3(2, 0, 0)) << "carrier widened the extent";
  EXPECT_EQ(s.bounds().max, glm::vec3(2, 0, 0)) << "carrier widened the scene bounds";

  // Turning an appearance Gaussian into a carrier takes it out of the counts.
  ASSERT_TRUE(s.begin_next_epoch().ok());
  Gaussian g = *s.find(GaussianId{2});
  g.carrier = true;
  ASSERT_TRUE(s.modify(g).ok());
  ASSERT_TRUE(s.commit_epoch().ok());
  EXPECT_EQ(s.appearance_count(), 1u);
  EXPECT_EQ(raw(s.find_object(ObjectId{4})->members), (std::vector<std::uint64_t>{1}));
}

TEST(SceneStore, ObjectsRecomputedAtCommit) {
  SceneStore s;
  ASSERT_TRUE(s.begin_next_epoch().ok());
  ASSERT_TRUE(s.set_object(ObjectId{1}, "table").ok());
  ASSERT_TRUE(s.insert(make(1, {0, 0, 0}, 1)).ok());
  ASSERT_TRUE(s.insert(make(2, {2, 4, 0}, 1)).ok());
  ASSERT_TRUE(s.insert(make(3, {5, 5, 5}, 2)).ok());  // undeclared object 2
  ASSERT_TRUE(s.insert(make(4, {-1, -1, -1})).ok());
  ASSERT_TRUE(s.commit_epoch().ok());
  ASSERT_EQ(s.objects().size(), 2u);
  EXPECT_TRUE(s.changes(Epoch{1})->objects_changed);
  const SemanticObject* t = s.find_object(ObjectId{1});
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->label, "table");
  EXPECT_EQ(t->centroid, glm::vec3(1, 2, 0));
  EXPECT_EQ(t->extent_min, glm::vec3(0, 0, 0));
  EXPECT_EQ(t->extent_max, glm::vec3(2, 4, 0));
  EXPECT_EQ(s.find_object(ObjectId{2})->label, "") << "undeclared object should be unlabelled";
  EXPECT_EQ(s.bounds().min, glm::vec3(-1, -1, -1));

  // Moving a Gaussian between objects and removing one updates both objects.
  ASSERT_TRUE(s.begin_next_epoch().ok());
  Gaussian g = *s.find(GaussianId{2});
  g.object = ObjectId{2};
  ASSERT_TRUE(s.modify(g).ok());
  ASSERT_TRUE(s.remove(GaussianId{3}).ok());
  ASSERT_TRUE(s.commit_epoch().ok());
  EXPECT_TRUE(s.changes(Epoch{2})->objects_changed);
  EXPECT_EQ(raw(s.find_object(ObjectId{1})->members), (std::vector<std::uint64_t>{1}));
  EXPECT_EQ(s.find_object(ObjectId{1})->centroid, glm::vec3(0, 0, 0));
  EXPECT_EQ(raw(s.find_object(ObjectId{2})->members), (std::vector<std::uint64_t>{2}));
  EXPECT_EQ(s.find_object(ObjectId{2})->extent_max, glm::vec3(2, 4, 0));

  // An epoch touching only unlabelled Gaussians leaves objects unchanged.
  ASSERT_TRUE(s.begin_next_epoch().ok());
  Gaussian u = *s.find(GaussianId{4});
  u.support = 3;
  ASSERT_TRUE(s.modify(u).ok());
  ASSERT_TRUE(s.commit_epoch().ok());
  EXPECT_FALSE(s.changes(Epoch{3})->objects_changed);

  ASSERT_TRUE(s.begin_next_epoch().ok());
  EXPECT_FALSE(s.set_object(ObjectId{-1}, "x").ok());
  EXPECT_FALSE(s.set_object(ObjectId{5}, "").ok());
  EXPECT_FALSE(s.set_object(ObjectId{5}, "lamp", 1.5f).ok());
  EXPECT_FALSE(s.remove_object(ObjectId{9}).ok());
  ASSERT_TRUE(s.remove_object(ObjectId{1}).ok());
  ASSERT_TRUE(s.commit_epoch().ok());
  EXPECT_EQ(s.find_object(ObjectId{1})->label, "") << "removed declaration keeps members, loses label";
}

TEST(SceneStore, SurfaceChunksCarryTheirEpochAndAreValidated) {
  SceneStore s;
  ASSERT_TRUE(s.begin_epoch(Epoch{3}).ok());
  SurfaceChunk c;
  c.chunk_id = 9;
  c.epoch = Epoch{100};  // forced to the open epoch
  c.mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  c.mesh.colors = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}};
  c.mesh.indices = {0, 1, 2};
  ASSERT_TRUE(s.set_surface_chunk(c).ok());
  SurfaceChunk bad = c;
  bad.chunk_id = 10;
  bad.mesh.indices = {0, 1, 3};
  EXPECT_FALSE(s.set_surface_chunk(bad).ok());
  bad.mesh.indices = {0, 1};
  EXPECT_FALSE(s.set_surface_chunk(bad).ok());
  bad.mesh.indices = {0, 1, 2};
  bad.mesh.colors.pop_back();
  EXPECT_FALSE(s.set_surface_chunk(bad).ok());
  ASSERT_TRUE(s.commit_epoch().ok());
  ASSERT_EQ(s.surface_chunks().size(), 1u);
  EXPECT_EQ(s.surface_chunks()[0].epoch, Epoch{3});
  EXPECT_EQ(s.changes(Epoch{3})->chunks_changed, (std::vector<std::uint32_t>{9}));
  ASSERT_TRUE(s.begin_next_epoch().ok());
  EXPECT_FALSE(s.remove_surface_chunk(10).ok());
  ASSERT_TRUE(s.remove_surface_chunk(9).ok());
  ASSERT_TRUE(s.commit_epoch().ok());
  EXPECT_TRUE(s.surface_chunks().empty());
}

TEST(SceneStore, RoomBeyondWhatTheProcessCanHaveIsRefusedWithTheStoreUnchanged) {
  SceneStore s;
  ASSERT_TRUE(s.begin_next_epoch().ok());
  for (std::uint64_t i = 1; i <= 3; ++i) ASSERT_TRUE(s.insert(make(i, glm::vec3(float(i)))).ok());
  ASSERT_TRUE(s.commit_epoch().ok());
  // 2^40 Gaussians: far beyond any machine this runs on.
  const std::size_t huge = std::size_t{1} << 40;
  EXPECT_GE(s.bytes_to_hold(huge), huge * sizeof(Gaussian));
  const Status refused = s.reserve(huge);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("not enough memory: a scene of 1099511627776 Gaussians needs about"),
            std::string::npos)
      << refused.message();
  EXPECT_NE(refused.message().find("this process can have"), std::string::npos) << refused.message();
  EXPECT_EQ(s.size(), 3u);
  EXPECT_EQ(s.epoch(), Epoch{1});
  EXPECT_FALSE(s.in_epoch());
  // Room that fits is taken, and nothing is asked for a span the store already has.
  EXPECT_EQ(s.bytes_to_hold(2), 0u);
  EXPECT_TRUE(s.reserve(1000).ok());
  EXPECT_GT(s.bytes_to_hold(1001), 0u);
  EXPECT_LT(s.bytes_to_hold(1001), s.bytes_to_hold(5000));
  ASSERT_TRUE(s.begin_next_epoch().ok());
  EXPECT_FALSE(s.reserve(2000).ok());  // not while an epoch is open
  ASSERT_TRUE(s.insert(make(4, glm::vec3(4.0f))).ok());
  ASSERT_TRUE(s.commit_epoch().ok());
  EXPECT_EQ(s.size(), 4u);
}

TEST(SceneStore, ChangeLogIsBounded) {
  SceneStore s(3);
  for (int e = 0; e < 5; ++e) {
    ASSERT_TRUE(s.begin_next_epoch().ok());
    ASSERT_TRUE(s.commit_epoch().ok());
  }
  EXPECT_EQ(s.change_log().size(), 3u);
  EXPECT_EQ(s.changes(Epoch{2}), nullptr);
  EXPECT_NE(s.changes(Epoch{5}), nullptr);
}

}  // namespace
}  // namespace gauss
