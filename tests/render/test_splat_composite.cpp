// Mesh + Gaussian composite, stereo, highlight and edit tints, and the real scenes:
// GPU against the CPU reference, plus goldens.
#include <gtest/gtest.h>

#include "gauss/engine/ply_gaussian.h"
#include "gauss/render/splat_renderer.h"
#include "golden.h"
#include "splat_test_util.h"
#include "vk_test.h"

namespace gauss::test {
namespace {

// A coloured quad at depth 3.5 covering the centre of forward_camera's view, and a
// triangle tilted through the splat volume (so splats lie in front, behind and on it).
TriangleMesh test_mesh() {
  TriangleMesh m;
  m.positions = {{-0.8f, -0.6f, 3.5f}, {0.8f, -0.6f, 3.5f}, {0.8f, 0.6f, 3.5f}, {-0.8f, 0.6f, 3.5f},
                 {-1.5f, 0.9f, 2.0f},  {1.5f, 0.9f, 2.0f},  {0.0f, -0.9f, 6.0f}};
  m.colors = {{200, 40, 40}, {40, 200, 40}, {40, 40, 200}, {200, 200, 40}, {90, 90, 90}, {250, 250, 250}, {0, 120, 160}};
  m.indices = {0, 1, 2, 0, 2, 3, 4, 5, 6};
  return m;
}

class SplatComposite : public VkTest {
 protected:
  std::unique_ptr<render::SplatRenderer> make(std::uint32_t capacity, int degree, std::uint32_t w, std::uint32_t h) {
    auto r = render::SplatRenderer::create(context(), {.capacity = capacity, .sh_degree = degree, .max_width = w,
                                                       .max_height = h});
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.message());
    return r.ok() ? std::move(*r) : nullptr;
  }
  ImageRGBA8 image(render::SplatRenderer& r) {
    auto img = r.read_image();
    EXPECT_TRUE(img.ok()) << (img.ok() ? "" : img.message());
    return img.ok() ? *img : ImageRGBA8{};
  }
};

TEST_F(SplatComposite, MeshAndGaussiansMatchReference) {
  const auto scene = procedural_scene(2500, 1, 21);
  const Camera cam = forward_camera(240, 180);
  const TriangleMesh mesh = test_mesh();
  render::SplatRenderOptions opt;
  opt.clear_colour = {0.1f, 0.1f, 0.15f};

  // The mesh layer as the mesh pass leaves it: colour from a renderer with no splats.
  auto bare = make(1, 1, 240, 180);
  ASSERT_TRUE(bare && bare->set_mesh(mesh).ok());
  ASSERT_TRUE(bare->render(cam, opt).ok());
  const ImageRGBA8 mesh_colour = image(*bare);
  auto depth = bare->read_mesh_depth();
  ASSERT_TRUE(depth.ok()) << depth.message();
  std::size_t covered = 0;
  for (float d : *depth) covered += std::isfinite(d) ? 1 : 0;
  EXPECT_GT(covered, depth->size() / 4);

  auto r = make(2500, 1, 240, 180);
  ASSERT_TRUE(r && r->write_slots(0, scene).ok());
  ASSERT_TRUE(r->set_mesh(mesh).ok());
  auto stats = r->render(cam, opt);
  ASSERT_TRUE(stats.ok()) << stats.message();
  const ImageRGBA8 gpu = image(*r);

  render::MeshLayer layer{&mesh_colour, *depth, render::kDefaultMeshMargin};
  render::ReferenceOptions ro;
  ro.clear_colour = glm::dvec3(opt.clear_colour);
  ro.mesh = &layer;
  auto ref = render::render_reference(scene, {}, 1, cam, ro);
  ASSERT_TRUE(ref.ok()) << ref.message();
  std::printf("visible GPU %u (mesh tiles culled in binning) / reference %llu (culled behind mesh %llu)\n",
              stats->visible, static_cast<unsigned long long>(ref->stats.visible),
              static_cast<unsigned long long>(ref->stats.culled_mesh));
  EXPECT_TRUE(close_to_reference(ref->rgba8, gpu, "splat_mesh_composite"));
  EXPECT_GOLDEN(context(), gpu, "splat_mesh_composite", ref->rgba8);

  // Clearing the mesh brings back the plain splat image.
  r->clear_mesh();
  ASSERT_TRUE(r->render(cam, opt).ok());
  render::ReferenceOptions plain;
  plain.clear_colour = ro.clear_colour;
  auto ref_plain = render::render_reference(scene, {}, 1, cam, plain);
  ASSERT_TRUE(ref_plain.ok());
  EXPECT_TRUE(close_to_reference(ref_plain->rgba8, image(*r), "splat_mesh_cleared"));
}

TEST_F(SplatComposite, BadMeshIsRejectedAndTheOldOneKept) {
  auto r = make(4, 0, 64, 48);
  ASSERT_TRUE(r && r->set_mesh(test_mesh()).ok());
  TriangleMesh bad = test_mesh();
  bad.indices.push_back(99);
  bad.indices.push_back(0);
  bad.indices.push_back(1);
  auto st = r->set_mesh(bad);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("out of range"), std::string::npos) << st.message();
  EXPECT_TRUE(r->has_mesh());
  bad = test_mesh();
  bad.colors.pop_back();
  EXPECT_FALSE(r->set_mesh(bad).ok());
}

TEST_F(SplatComposite, StereoEqualsTwoMonoRendersAndTheReference) {
  const auto scene = procedural_scene(2000, 2, 5);
  const Camera centre = forward_camera(200, 150);
  const Camera left = render::stereo_eye_camera(centre, 0.064, render::Eye::Left);
  const Camera right = render::stereo_eye_camera(centre, 0.064, render::Eye::Right);
  auto r = make(2000, 2, 200, 150);
  ASSERT_TRUE(r && r->write_slots(0, scene).ok());
  auto st = r->render_stereo(left, right);
  ASSERT_TRUE(st.ok()) << st.message();
  auto l = r->read_image(0);
  auto rr = r->read_image(1);
  ASSERT_TRUE(l.ok() && rr.ok());
  EXPECT_FALSE(images_equal(*l, *rr, "splat_stereo_eyes_differ"));
  ASSERT_TRUE(r->render(left).ok());
  EXPECT_TRUE(images_equal(image(*r), *l, "splat_stereo_left_vs_mono"));
  ASSERT_TRUE(r->render(right).ok());
  EXPECT_TRUE(images_equal(image(*r), *rr, "splat_stereo_right_vs_mono"));
  auto ref_l = render::render_reference(scene, {}, 2, left);
  auto ref_r = render::render_reference(scene, {}, 2, right);
  ASSERT_TRUE(ref_l.ok() && ref_r.ok());
  EXPECT_TRUE(close_to_reference(ref_l->rgba8, *l, "splat_stereo_left"));
  EXPECT_TRUE(close_to_reference(ref_r->rgba8, *rr, "splat_stereo_right"));
  EXPECT_GOLDEN(context(), *l, "splat_stereo_left", ref_l->rgba8);
  EXPECT_GOLDEN(context(), *rr, "splat_stereo_right", ref_r->rgba8);
  EXPECT_EQ((*st)[0].views_together, r->pass_profile().views_together) << r->pass_profile().views_reason;
}

// Two views recorded together (each step for both eyes between the same two barriers,
// each eye with its own scratch) give the same images, counts and overflow as the eyes
// one after the other: with a mesh, highlight and edit tints, a pair budget both eyes
// overflow, replayed passes (and passes recorded into every frame), and a mono frame
// between stereo frames.
TEST_F(SplatComposite, StereoViewsTogetherEqualTheEyesOneAfterTheOther) {
  const auto scene = procedural_scene(2000, 1, 17);
  const Camera centre = forward_camera(160, 120);
  const Camera left = render::stereo_eye_camera(centre, 0.064, render::Eye::Left);
  const Camera right = render::stereo_eye_camera(centre, 0.064, render::Eye::Right);
  auto make_with = [&](std::optional<bool> together, std::uint32_t max_pairs, bool reuse = true) {
    auto r = render::SplatRenderer::create(context(), {.capacity = 2000, .sh_degree = 1, .max_width = 160,
                                                       .max_height = 120, .max_pairs = max_pairs,
                                                       .reuse_recorded_passes = reuse, .views_together = together});
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.message());
    if (!r.ok()) return std::unique_ptr<render::SplatRenderer>{};
    const std::vector<ObjectId> lit = {ObjectId{2}};
    EXPECT_TRUE((*r)->write_slots(0, scene).ok());
    EXPECT_TRUE((*r)->set_mesh(test_mesh()).ok());
    EXPECT_TRUE((*r)->set_highlight(lit).ok());
    for (std::uint32_t s = 0; s < scene.size(); s += 5)
      EXPECT_TRUE((*r)->set_edit_tint(SlotIndex{s}, {render::EditTintKind::Added, 0}).ok());
    return std::move(*r);
  };
  // The pairs each eye needs, then a budget of about half of them.
  auto probe = make_with(false, 0);
  ASSERT_TRUE(probe);
  auto needed = probe->render_stereo(left, right);
  ASSERT_TRUE(needed.ok()) << needed.message();
  const std::uint32_t budget = std::min((*needed)[0].pairs_needed, (*needed)[1].pairs_needed) / 2;
  ASSERT_GT(budget, 1000u);

  auto together = make_with(true, budget);
  auto apart = make_with(false, budget);
  auto recorded = make_with(true, budget, /*reuse=*/false);  // together, recorded into every frame
  ASSERT_TRUE(together && apart && recorded);
  EXPECT_TRUE(together->pass_profile().views_together) << together->pass_profile().views_reason;
  auto same_stereo = [&](const char* what, bool replayed) {
    SCOPED_TRACE(what);
    auto a = together->render_stereo(left, right);
    auto b = apart->render_stereo(left, right);
    auto c = recorded->render_stereo(left, right);
    ASSERT_TRUE(a.ok() && b.ok() && c.ok()) << (!a.ok() ? a.message() : !b.ok() ? b.message() : c.message());
    for (int eye = 0; eye < 2; ++eye) {
      SCOPED_TRACE(eye == 0 ? "left" : "right");
      EXPECT_TRUE((*a)[eye].views_together);
      EXPECT_FALSE((*b)[eye].views_together);
      EXPECT_EQ((*a)[eye].passes_replayed, replayed);
      EXPECT_EQ((*a)[eye].visible, (*b)[eye].visible);
      EXPECT_EQ((*a)[eye].pairs, (*b)[eye].pairs);
      EXPECT_EQ((*a)[eye].pairs_needed, (*b)[eye].pairs_needed);
      EXPECT_TRUE((*a)[eye].pair_overflow);
      EXPECT_EQ((*a)[eye].pair_overflow, (*b)[eye].pair_overflow);
      auto ia = together->read_image(static_cast<std::uint32_t>(eye));
      auto ib = apart->read_image(static_cast<std::uint32_t>(eye));
      ASSERT_TRUE(ia.ok() && ib.ok());
      EXPECT_TRUE(images_equal(*ib, *ia, eye == 0 ? "splat_stereo_together_left" : "splat_stereo_together_right"));
      auto ic = recorded->read_image(static_cast<std::uint32_t>(eye));
      ASSERT_TRUE(ic.ok());
      EXPECT_TRUE(images_equal(*ib, *ic, eye == 0 ? "splat_stereo_recorded_left" : "splat_stereo_recorded_right"));
      EXPECT_TRUE((*c)[eye].views_together);
      EXPECT_FALSE((*c)[eye].passes_replayed);
    }
    // The right eye's passes ran within the left eye's timestamps: its own spans are 0.
    EXPECT_EQ((*a)[1].gpu.total_ms, 0.0);
    EXPECT_EQ((*a)[1].gpu.blend_ms, 0.0);
  };
  same_stereo("first stereo frame", false);
  same_stereo("second stereo frame (replayed passes)", true);
  // A mono frame between stereo frames: recorded alone, then the pair recorded again.
  auto ma = together->render(left);
  auto mb = apart->render(left);
  ASSERT_TRUE(ma.ok() && mb.ok() && recorded->render(left).ok());
  EXPECT_FALSE(ma->views_together);
  EXPECT_TRUE(images_equal(image(*apart), image(*together), "splat_stereo_together_mono"));
  same_stereo("stereo after a mono frame", false);
}

TEST_F(SplatComposite, HighlightAndEditTintsMatchReference) {
  const auto scene = procedural_scene(1500, 0, 9);
  const Camera cam = forward_camera(200, 150);
  auto r = make(1500, 0, 200, 150);
  ASSERT_TRUE(r && r->write_slots(0, scene).ok());
  ASSERT_TRUE(r->render(cam).ok());
  const ImageRGBA8 untinted = image(*r);

  // A highlight of an object nobody has turns the tint path on without changing a byte.
  const ObjectId nobody{1000};
  ASSERT_TRUE(r->set_highlight(std::span(&nobody, 1)).ok());
  ASSERT_TRUE(r->render(cam).ok());
  EXPECT_TRUE(images_equal(untinted, image(*r), "splat_tint_noop"));

  const std::vector<ObjectId> lit = {ObjectId{2}, ObjectId{5}};
  ASSERT_TRUE(r->set_highlight(lit).ok());
  std::vector<render::EditTintState> tints(scene.size());
  for (std::uint32_t s = 0; s < scene.size(); ++s) {
    if (s % 7 == 0) tints[s] = {render::EditTintKind::Added, s % 10};
    if (s % 7 == 1) tints[s] = {render::EditTintKind::Replaced, s % 9};
    if (s % 7 == 2) tints[s] = {render::EditTintKind::Removed, s % 11};
    if (tints[s].kind != render::EditTintKind::None) {
      ASSERT_TRUE(r->set_edit_tint(SlotIndex{s}, tints[s]).ok());
    }
  }
  ASSERT_TRUE(r->render(cam).ok());
  const ImageRGBA8 gpu = image(*r);
  render::ReferenceOptions ro;
  ro.highlight_objects = lit;
  ro.edit_tints = tints;
  auto ref = render::render_reference(scene, {}, 0, cam, ro);
  ASSERT_TRUE(ref.ok()) << ref.message();
  EXPECT_TRUE(close_to_reference(ref->rgba8, gpu, "splat_tints"));
  EXPECT_GOLDEN(context(), gpu, "splat_tints", ref->rgba8);

  // Every frame ages the tints by one: the next frame equals the reference with age + 1.
  for (auto& t : tints) ++t.age;
  ASSERT_TRUE(r->render(cam).ok());
  auto ref_next = render::render_reference(scene, {}, 0, cam, ro);
  ASSERT_TRUE(ref_next.ok());
  EXPECT_TRUE(close_to_reference(ref_next->rgba8, image(*r), "splat_tints_next_frame"));

  // After the fade every removed Gaussian is gone and added/replaced are plain again.
  for (int f = 0; f < 12; ++f) ASSERT_TRUE(r->render(cam).ok());
  r->clear_highlight();
  ASSERT_TRUE(r->render(cam).ok());
  std::vector<Gaussian> without_removed = scene;
  std::vector<std::uint8_t> occupied(scene.size(), 1);
  for (std::uint32_t s = 0; s < scene.size(); ++s)
    if (s % 7 == 2) occupied[s] = 0;
  auto ref_faded = render::render_reference(scene, occupied, 0, cam);
  ASSERT_TRUE(ref_faded.ok());
  EXPECT_TRUE(close_to_reference(ref_faded->rgba8, image(*r), "splat_tints_faded"));
}

// Real scenes from the shared data (skipped when absent), seen by scene_camera().
TEST_F(SplatComposite, RealSceneGuitarMatchesReference) {
  GAUSS_REQUIRE_DATA(path, "splats/guitar.ply");
  auto scene = read_gaussian_ply(path);
  ASSERT_TRUE(scene.ok()) << scene.message();
  const auto& gs = scene->cloud.gaussians;
  const Camera cam = scene_camera(gs, 320, 240, 6.0);
  auto r = make(static_cast<std::uint32_t>(gs.size()), scene->cloud.sh_degree, 320, 240);
  ASSERT_TRUE(r && r->write_slots(0, gs).ok());
  auto st = r->render(cam);
  ASSERT_TRUE(st.ok()) << st.message();
  std::printf("guitar: %zu Gaussians, visible %u, pairs %u\n", gs.size(), st->visible, st->pairs);
  auto ref = render::render_reference(gs, {}, scene->cloud.sh_degree, cam);
  ASSERT_TRUE(ref.ok()) << ref.message();
  const ImageRGBA8 gpu = image(*r);
  EXPECT_TRUE(close_to_reference(ref->rgba8, gpu, "splat_real_guitar"));
  EXPECT_GOLDEN(context(), gpu, "splat_real_guitar", ref->rgba8);
}

TEST_F(SplatComposite, RealSceneFruitDropsSh3MatchesReference) {
  GAUSS_REQUIRE_DATA(path, "splats/fruit_drops_sh3.ply");
  auto scene = read_gaussian_ply(path);
  ASSERT_TRUE(scene.ok()) << scene.message();
  const auto& gs = scene->cloud.gaussians;
  ASSERT_EQ(scene->cloud.sh_degree, 3);
  const Camera cam = scene_camera(gs, 320, 240, 25.0);
  auto r = make(static_cast<std::uint32_t>(gs.size()), 3, 320, 240);
  ASSERT_TRUE(r && r->write_slots(0, gs).ok());
  auto st = r->render(cam);
  ASSERT_TRUE(st.ok()) << st.message();
  std::printf("fruit_drops: %zu Gaussians, visible %u, pairs %u\n", gs.size(), st->visible, st->pairs);
  auto ref = render::render_reference(gs, {}, 3, cam);
  ASSERT_TRUE(ref.ok()) << ref.message();
  const ImageRGBA8 gpu = image(*r);
  EXPECT_TRUE(close_to_reference(ref->rgba8, gpu, "splat_real_fruit_drops"));
  EXPECT_GOLDEN(context(), gpu, "splat_real_fruit_drops", ref->rgba8);
}

}  // namespace
}  // namespace gauss::test
