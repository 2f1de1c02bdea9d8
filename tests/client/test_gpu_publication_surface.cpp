// GpuPublication's surface path in its two halves: prepare_surface (on a publication
// thread, under the state lock: which chunks to remove, changed chunks checked and in the
// mesh pass's vertex layout) and publish_prepared_surface (the display thread: buffers and
// uploads only). Checked against the renderer's mesh: adds, an unchanged stage, a refused
// chunk keeping its previous version, a removal, and a host restart re-sending everything.
#include <cmath>
#include <limits>
#include <thread>

#include <gtest/gtest.h>

#include "gauss/client/gpu_publication.h"
#include "gauss/engine/surface_stage.h"
#include "vk_test.h"

namespace gauss::test {
namespace {

TriangleMesh triangle(float x) {
  TriangleMesh m;
  m.positions = {{x, 0.0f, 2.0f}, {x + 1.0f, 0.0f, 2.0f}, {x, 1.0f, 2.0f}};
  m.colors = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}};
  m.indices = {0, 1, 2};
  return m;
}

class GpuPublicationSurface : public VkTest {
 protected:
  void SetUp() override {
    VkTest::SetUp();
    if (IsSkipped()) return;
    auto r = render::SplatRenderer::create(context(), {.capacity = 16, .max_width = 32, .max_height = 32});
    ASSERT_TRUE(r.ok()) << r.message();
    renderer = std::move(*r);
  }
  void offer(std::uint64_t id, std::uint64_t epoch, TriangleMesh mesh) {
    ASSERT_TRUE(stage.offer(StagedChunk{id, Epoch{epoch}, std::move(mesh)}).ok());
  }
  // Prepared on another thread, as the publication thread does, then published here.
  std::uint32_t publish() {
    client::PreparedSurface prepared;
    std::thread([&] { prepared = publication.prepare_surface(stage); }).join();
    return publication.publish_prepared_surface(prepared, *renderer);
  }

  std::unique_ptr<render::SplatRenderer> renderer;
  SurfaceStage stage;
  client::GpuPublication publication;
};

TEST_F(GpuPublicationSurface, PreparedChangesReachTheRenderer) {
  offer(1, 1, triangle(0.0f));
  offer(2, 1, triangle(2.0f));
  ASSERT_EQ(stage.commit(Epoch{1}), 2u);
  EXPECT_EQ(publish(), 2u);
  EXPECT_EQ(renderer->mesh_chunk_count(), 2u);
  EXPECT_EQ(publication.stats().chunks_set, 2u);

  // Nothing moved: nothing prepared, nothing changed.
  const client::PreparedSurface idle = publication.prepare_surface(stage);
  EXPECT_FALSE(idle.changed);
  EXPECT_EQ(publish(), 0u);

  // Chunk 2 replaced by a mesh the pass refuses (a non-finite vertex): refused, counted,
  // named; its previous version stays on show. Chunk 1 removed.
  TriangleMesh bad = triangle(2.0f);
  bad.positions[1].x = std::numeric_limits<float>::quiet_NaN();
  offer(2, 2, bad);
  offer(1, 2, TriangleMesh{});
  ASSERT_EQ(stage.commit(Epoch{2}), 2u);
  const client::PreparedSurface p = publication.prepare_surface(stage);
  ASSERT_TRUE(p.changed);
  ASSERT_EQ(p.removed.size(), 1u);
  EXPECT_EQ(p.removed[0], 1u);
  ASSERT_EQ(p.sets.size(), 1u);
  EXPECT_NE(p.sets[0].error.find("chunk 2"), std::string::npos) << p.sets[0].error;
  EXPECT_EQ(publication.publish_prepared_surface(p, *renderer), 1u);  // the removal
  EXPECT_EQ(renderer->mesh_chunk_count(), 1u);
  EXPECT_EQ(publication.stats().chunks_refused, 1u);
  EXPECT_NE(publication.stats().last_refusal.find("non-finite"), std::string::npos);
  EXPECT_EQ(publication.gpu_chunk_count(), 1u);

  // A host restart: epochs mean nothing any more, so the held chunk is set again even
  // though its new epoch equals the one held.
  stage.restart_epochs();
  offer(2, 1, triangle(4.0f));
  ASSERT_EQ(stage.commit(Epoch{1}), 1u);
  EXPECT_EQ(publish(), 1u);
  EXPECT_EQ(publication.stats().chunks_set, 3u);
  EXPECT_EQ(renderer->mesh_chunk_count(), 1u);
}

}  // namespace
}  // namespace gauss::test
