// CPU reference rasterizer: hand-computed values, order, early stop, culls, mesh, tints,
// stereo and the image metrics. CPU only (no Vulkan).
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/render/image_metrics.h"
#include "gauss/render/reference_rasterizer.h"
#include "gauss/render/splat_math.h"

namespace gauss::render {
namespace {

// 64x64, f = 100, principal point at the image centre, camera at the origin looking down +z.
Camera test_camera(double cx = 32.0, double cy = 32.0) {
  Camera c;
  c.width = 64;
  c.height = 64;
  c.fx = c.fy = 100.0;
  c.cx = cx;
  c.cy = cy;
  return c;
}

Gaussian iso(glm::vec3 pos, float sigma, glm::vec3 dc, float logit = 0.0f) {
  Gaussian g;
  g.position = pos;
  g.log_scale = glm::vec3(std::log(sigma));
  g.sh_dc = dc;
  g.opacity_logit = logit;
  return g;
}

glm::dvec3 rgb_at(const ReferenceImage& im, std::uint32_t row, std::uint32_t col) {
  const std::size_t px = std::size_t(row) * im.width + col;
  return {im.rgb[px * 3], im.rgb[px * 3 + 1], im.rgb[px * 3 + 2]};
}

// Colour (SH degree 0) that the DC coefficient dc produces: C0 dc + 0.5.
float dc_for(double colour) { return float((colour - 0.5) / kShC0); }

TEST(ReferenceRasterizer, SingleGaussianMatchesHandComputation) {
  // log-scale -3 (exact in float): sigma = e^-3 m at 5 m with f = 100, J = diag(20, 20),
  // a = c = 400 e^-6 + 0.3 = 1.2915008706665434, b = 0.
  std::vector<Gaussian> g = {iso({0.0f, 0.0f, 5.0f}, 0.05f, {1.0f, 0.0f, -1.0f})};
  g[0].log_scale = glm::vec3(-3.0f);
  const double a = 1.2915008706665434;
  const ProjectedSplat s = project_splat(g[0], 0, 0, test_camera());
  ASSERT_EQ(s.cull, SplatCull::Visible);
  EXPECT_NEAR(s.cov2d.x, a, 1e-14);
  EXPECT_NEAR(s.cov2d.y, 0.0, 1e-14);
  EXPECT_NEAR(s.cov2d.z, a, 1e-14);
  EXPECT_NEAR(s.conic.x, 1.0 / a, 1e-14);
  EXPECT_EQ(s.radius, 4.0);  // ceil(3 sqrt(a + sqrt(0.1))) = ceil(3.80)
  EXPECT_EQ(s.u, 32.0);
  EXPECT_EQ(s.v, 32.0);
  EXPECT_EQ(s.tile_min_x, 1u);  // trunc(28 / 16)
  EXPECT_EQ(s.tile_max_x, 3u);  // trunc(51 / 16)
  EXPECT_NEAR(s.opacity, 0.5, 1e-15);
  EXPECT_EQ(s.depth_key, 5.0f);

  auto im = render_reference(g, {}, 0, test_camera());
  ASSERT_TRUE(im) << im.message();
  // Pixel (31, 31) samples (31.5, 31.5): dx = dy = 0.5, power = -0.25 / a,
  // alpha = 0.5 exp(power) = 0.41200474431660383, colour = (C0 + 0.5, 0.5, 0.5 - C0).
  const glm::dvec3 c = rgb_at(*im, 31, 31);
  EXPECT_NEAR(c.x, 0.32222676471614414, 1e-14);
  EXPECT_NEAR(c.y, 0.20600237215830192, 1e-14);
  EXPECT_NEAR(c.z, 0.08977797960045966, 1e-14);
  EXPECT_NEAR(im->transmittance[31 * 64 + 31], 1.0 - 0.41200474431660383, 1e-14);
  const std::uint8_t* p = &im->rgba8.pixels[(31 * 64 + 31) * 4];
  EXPECT_EQ(p[0], 82);
  EXPECT_EQ(p[1], 53);
  EXPECT_EQ(p[2], 23);
  EXPECT_EQ(p[3], 255);
  // Symmetric pixel (32, 32): same distance to the centre.
  EXPECT_NEAR(rgb_at(*im, 32, 32).x, c.x, 1e-15);
  // Outside the touched tiles (tile 0 and tile 3) nothing is evaluated: exactly background.
  EXPECT_EQ(rgb_at(*im, 5, 5), glm::dvec3(0.0));
  EXPECT_EQ(im->transmittance[50 * 64 + 50], 1.0);
  EXPECT_EQ(im->stats.visible, 1u);
  EXPECT_EQ(im->stats.tile_pairs, 4u);
}

TEST(ReferenceRasterizer, PixelSamplePointIsTheOpenCvPixelCentre) {
  // Centre at u = v = 32.5: pixel (32, 32) is hit at power 0 exactly.
  const std::vector<Gaussian> g = {iso({0.0f, 0.0f, 5.0f}, 0.05f, {dc_for(1.0), dc_for(1.0), dc_for(1.0)})};
  auto im = render_reference(g, {}, 0, test_camera(32.5, 32.5));
  ASSERT_TRUE(im) << im.message();
  EXPECT_NEAR(rgb_at(*im, 32, 32).x, 0.5, 1e-7);  // alpha = opacity = 0.5, colour 1 (float dc)
  EXPECT_NEAR(rgb_at(*im, 31, 32).x, rgb_at(*im, 33, 32).x, 1e-15);
  EXPECT_LT(rgb_at(*im, 31, 32).x, 0.5);
}

TEST(ReferenceRasterizer, FrontToBackOrderIndependentOfSlotOrder) {
  const Gaussian near_red = iso({0.0f, 0.0f, 4.0f}, 0.05f, {dc_for(1.0), dc_for(0.0), dc_for(0.0)});
  const Gaussian far_green = iso({0.0f, 0.0f, 6.0f}, 0.05f, {dc_for(0.0), dc_for(1.0), dc_for(0.0)});
  const Camera cam = test_camera(32.5, 32.5);
  auto a = render_reference(std::vector<Gaussian>{near_red, far_green}, {}, 0, cam);
  auto b = render_reference(std::vector<Gaussian>{far_green, near_red}, {}, 0, cam);
  ASSERT_TRUE(a && b);
  const glm::dvec3 c = rgb_at(*a, 32, 32);
  // At the centre pixel both alphas are 0.5: red 0.5, green 0.5 * (1 - 0.5).
  EXPECT_NEAR(c.x, 0.5, 1e-7);  // 1e-7: the colours come from float DC coefficients
  EXPECT_NEAR(c.y, 0.25, 1e-7);
  EXPECT_EQ(a->rgb, b->rgb);
}

TEST(ReferenceRasterizer, TransmittanceStopDoesNotBlendTheStoppingGaussian) {
  // Three alpha-0.99 layers (logit 20 -> opacity ~1, capped): after two, T = 1e-4; the third
  // would take T to 1e-6 < 1e-4, so the pixel stops and the blue layer is not blended.
  std::vector<Gaussian> g = {iso({0.0f, 0.0f, 4.0f}, 0.05f, {dc_for(1.0), dc_for(0.0), dc_for(0.0)}, 20.0f),
                             iso({0.0f, 0.0f, 5.0f}, 0.05f, {dc_for(0.0), dc_for(1.0), dc_for(0.0)}, 20.0f),
                             iso({0.0f, 0.0f, 6.0f}, 0.05f, {dc_for(0.0), dc_for(0.0), dc_for(1.0)}, 20.0f)};
  ReferenceOptions o;
  o.clear_colour = glm::dvec3(0.0, 0.0, 1.0);
  auto im = render_reference(g, {}, 0, test_camera(32.5, 32.5), o);
  ASSERT_TRUE(im) << im.message();
  const glm::dvec3 c = rgb_at(*im, 32, 32);
  const double T = im->transmittance[32 * 64 + 32];
  EXPECT_NEAR(T, 0.01 * 0.01, 1e-15);
  EXPECT_NEAR(c.x, 0.99, 1e-7);
  EXPECT_NEAR(c.y, 0.99 * 0.01, 1e-7);
  EXPECT_NEAR(c.z, T * 1.0, 1e-7);  // only the background's share: the blue layer is not blended
}

TEST(ReferenceRasterizer, NearCullAtPointTwoMetres) {
  // The camera's translation puts the Gaussian at t.z = 0.2 exactly (float 0.2f is above it).
  Camera cam = test_camera();
  cam.world_to_camera[3][2] = 0.2;
  Gaussian g = iso({0.0f, 0.0f, 0.0f}, 0.01f, {1.0f, 1.0f, 1.0f});
  EXPECT_EQ(project_splat(g, 0, 0, cam).view.z, 0.2);
  EXPECT_EQ(project_splat(g, 0, 0, cam).cull, SplatCull::Near);  // t.z <= 0.2
  g.position.z = 0.0001f;
  EXPECT_EQ(project_splat(g, 0, 0, cam).cull, SplatCull::Visible);
  g.position.z = -5.0f;  // behind the camera
  EXPECT_EQ(project_splat(g, 0, 0, cam).cull, SplatCull::Near);
  auto im = render_reference(std::vector<Gaussian>{g}, {}, 0, cam);
  ASSERT_TRUE(im);
  EXPECT_EQ(im->stats.culled_near, 1u);
  EXPECT_EQ(im->stats.visible, 0u);
}

TEST(ReferenceRasterizer, FrustumClampFeedsTheJacobianOnly) {
  // tan(half fov) = 64 / 200 = 0.32, limit 1.3 * 0.32 = 0.416. A centre at x/z = 1 is
  // clamped in J, while u uses the true projection.
  const Camera cam = test_camera();
  const double sigma = 0.1, z = 5.0;
  const Gaussian g = iso({float(z), 0.0f, float(z)}, float(sigma), {1.0f, 1.0f, 1.0f});
  const ProjectedSplat s = project_splat(g, 0, 0, cam);
  const double lim = 1.3 * 64.0 / 200.0;
  const double j00 = 100.0 / z, j02 = -100.0 * (lim * z) / (z * z);
  // Isotropic Sigma = sigma^2 I and W = I: a = sigma^2 (j00^2 + j02^2) + 0.3.
  const double s2 = std::exp(2.0 * double(g.log_scale.x));
  EXPECT_NEAR(s.cov2d.x, s2 * (j00 * j00 + j02 * j02) + kDilation, 1e-9);
  EXPECT_NEAR(s.cov2d.z, s2 * (j00 * j00) + kDilation, 1e-9);
  EXPECT_NEAR(s.u, 100.0 + 32.0, 1e-9);
  EXPECT_EQ(s.cull, SplatCull::OffScreen);  // 132 px + radius is off a 64 px image
  // Just inside the limit nothing is clamped: a = sigma^2 (f/z)^2 (1 + (x/z)^2) + 0.3.
  const Gaussian g2 = iso({float(0.4 * z), 0.0f, float(z)}, float(sigma), {1.0f, 1.0f, 1.0f});
  const ProjectedSplat s2p = project_splat(g2, 0, 0, cam);
  const double xz = double(float(0.4 * z)) / z;
  EXPECT_NEAR(s2p.cov2d.x, s2 * 400.0 * (1.0 + xz * xz) + kDilation, 1e-9);
}

TEST(ReferenceRasterizer, CameraPoseAndTileRectangleFollowTheReference) {
  // Camera moved to x = 1 (world_to_camera translation -1): a Gaussian at world x = 1 projects to cx.
  Camera cam = test_camera();
  cam.world_to_camera[3][0] = -1.0;
  const Gaussian g = iso({1.0f, 0.0f, 5.0f}, 0.05f, {1.0f, 1.0f, 1.0f});
  const ProjectedSplat s = project_splat(g, 0, 0, cam);
  EXPECT_NEAR(s.u, 32.0, 1e-6);
  // Off the left edge by more than the radius: empty rectangle.
  const Gaussian off = iso({-3.0f, 0.0f, 5.0f}, 0.05f, {1.0f, 1.0f, 1.0f});
  const ProjectedSplat so = project_splat(off, 0, 0, cam);
  EXPECT_EQ(so.cull, SplatCull::OffScreen);
}

TEST(ReferenceRasterizer, NonFiniteSlotsAreRejectedAndCounted) {
  std::vector<Gaussian> g = {iso({0.0f, 0.0f, 5.0f}, 0.05f, {1.0f, 1.0f, 1.0f}),
                             iso({0.0f, 0.0f, 5.0f}, 0.05f, {1.0f, 1.0f, 1.0f})};
  g[1].sh_rest[2].y = std::nanf("");
  auto deg0 = render_reference(g, {}, 0, test_camera());  // degree 0 does not read sh_rest
  auto deg1 = render_reference(g, {}, 1, test_camera());
  ASSERT_TRUE(deg0 && deg1);
  EXPECT_EQ(deg0->stats.rejected_nonfinite, 0u);
  EXPECT_EQ(deg1->stats.rejected_nonfinite, 1u);
  EXPECT_EQ(deg1->stats.visible, 1u);
  g[0].position.x = INFINITY;
  auto both = render_reference(g, {}, 1, test_camera());
  ASSERT_TRUE(both);
  EXPECT_EQ(both->stats.rejected_nonfinite, 2u);
  for (double v : both->rgb) EXPECT_EQ(v, 0.0);
}

TEST(ReferenceRasterizer, EmptySlotsAreSkipped) {
  std::vector<Gaussian> g = {iso({0.0f, 0.0f, 5.0f}, 0.05f, {1.0f, 1.0f, 1.0f}),
                             iso({0.0f, 0.0f, 4.0f}, 0.05f, {-1.0f, 1.0f, 1.0f})};
  const std::vector<std::uint8_t> occ = {1, 0};
  auto with_empty = render_reference(g, occ, 0, test_camera());
  auto only_first = render_reference(std::span<const Gaussian>(g.data(), 1), {}, 0, test_camera());
  ASSERT_TRUE(with_empty && only_first);
  EXPECT_EQ(with_empty->rgb, only_first->rgb);
  EXPECT_EQ(with_empty->stats.occupied, 1u);
}

TEST(ReferenceRasterizer, BadArgumentsAreErrorsNamingTheProblem) {
  const std::vector<Gaussian> g(2);
  Camera bad = test_camera();
  bad.fx = 0.0;
  EXPECT_FALSE(render_reference(g, {}, 0, bad));
  bad = test_camera();
  bad.world_to_camera[1][2] = NAN;
  auto r = render_reference(g, {}, 0, bad);
  ASSERT_FALSE(r);
  EXPECT_NE(r.message().find("world_to_camera"), std::string::npos);
  EXPECT_FALSE(render_reference(g, {}, 4, test_camera()));
  const std::vector<std::uint8_t> occ = {1};
  EXPECT_FALSE(render_reference(g, occ, 0, test_camera()));
  ReferenceOptions o;
  o.row_begin = 64;
  EXPECT_FALSE(render_reference(g, {}, 0, test_camera(), o));
  ImageRGBA8 small{4, 4, std::vector<std::uint8_t>(64, 0)};
  std::vector<float> depth(64 * 64, 1.0f);
  MeshLayer mesh{&small, depth, kDefaultMeshMargin};
  o = {};
  o.mesh = &mesh;
  EXPECT_FALSE(render_reference(g, {}, 0, test_camera(), o));
  ImageRGBA8 colour{64, 64, std::vector<std::uint8_t>(64 * 64 * 4, 0)};
  depth[100] = NAN;
  mesh = {&colour, depth, kDefaultMeshMargin};
  r = render_reference(g, {}, 0, test_camera(), o);
  ASSERT_FALSE(r);
  EXPECT_NE(r.message().find("pixel 100"), std::string::npos);
  depth[100] = 0.0f;  // "no triangle" must be +inf: 0 would cull everything
  r = render_reference(g, {}, 0, test_camera(), o);
  ASSERT_FALSE(r);
  EXPECT_NE(r.message().find("+inf"), std::string::npos);
  depth[100] = INFINITY;
  EXPECT_TRUE(render_reference(g, {}, 0, test_camera(), o));
}

TEST(ReferenceRasterizer, MeshOccludesBeyondTheMarginAndIsTheBackground) {
  // Mesh plane at depth 5 over the left half (grey), nothing on the right half.
  ImageRGBA8 colour{64, 64, std::vector<std::uint8_t>(64 * 64 * 4, 0)};
  std::vector<float> depth(64 * 64, INFINITY);
  for (std::uint32_t i = 0; i < 64; ++i)
    for (std::uint32_t j = 0; j < 32; ++j) {
      depth[i * 64 + j] = 5.0f;
      for (int c = 0; c < 3; ++c) colour.pixels[(i * 64 + j) * 4 + c] = 128;
    }
  MeshLayer mesh{&colour, depth, kDefaultMeshMargin};
  ReferenceOptions o;
  o.mesh = &mesh;
  const Camera cam = test_camera(32.0, 32.5);
  const float white = dc_for(1.0);
  // A Gaussian on the surface (5.01 m, inside the margin) straddling the mesh edge, one 1 m
  // behind it, and one behind the mesh over the mesh part only (culled in preprocess).
  std::vector<Gaussian> g = {iso({0.0f, 0.0f, 5.01f}, 0.05f, {white, white, white}),
                             iso({0.0f, 0.0f, 6.0f}, 0.1f, {white, white, white}),
                             iso({-1.0f, 0.0f, 6.0f}, 0.05f, {white, white, white})};
  auto im = render_reference(g, {}, 0, cam, o);
  ASSERT_TRUE(im) << im.message();
  EXPECT_EQ(im->stats.culled_mesh, 1u);
  EXPECT_EQ(im->stats.visible, 2u);
  // Left of the edge (mesh): only the surface Gaussian blends over the grey background.
  const double grey = 128.0 / 255.0;
  const double T_left = im->transmittance[32 * 64 + 31];
  EXPECT_LT(T_left, 1.0);
  EXPECT_NEAR(rgb_at(*im, 32, 31).x, (1.0 - T_left) * 1.0 + T_left * grey, 1e-7);
  // Far left (mesh, no Gaussian): exactly the mesh colour.
  EXPECT_NEAR(rgb_at(*im, 2, 2).x, grey, 1e-15);
  // Right of the edge (no mesh): both Gaussians blend, background black (the mesh colour there).
  auto no_mesh = render_reference(std::span<const Gaussian>(g.data(), 2), {}, 0, cam);
  ASSERT_TRUE(no_mesh);
  EXPECT_NEAR(rgb_at(*im, 32, 33).x, rgb_at(*no_mesh, 32, 33).x, 1e-15);
  // The preprocess cull changes nothing: the same scene without the culled Gaussian is equal.
  const std::vector<std::uint8_t> occ = {1, 1, 0};
  auto without = render_reference(g, occ, 0, cam, o);
  ASSERT_TRUE(without);
  EXPECT_EQ(without->rgb, im->rgb);
}

TEST(ReferenceRasterizer, HighlightAndEditTintsFollowTheFormulas) {
  const Camera cam = test_camera(32.5, 32.5);
  std::vector<Gaussian> g = {iso({0.0f, 0.0f, 5.0f}, 0.05f, {dc_for(0.2), dc_for(0.4), dc_for(0.6)})};
  g[0].object = ObjectId{7};
  const ProjectedSplat plain = project_splat(g[0], 0, 0, cam);
  const ProjectedSplat hl = project_splat(g[0], 0, 0, cam, true);
  EXPECT_NEAR(hl.colour.x, 0.2 + 0.5 * (1.0 - 0.2), 1e-6);
  EXPECT_NEAR(hl.colour.y, 0.4 + 0.5 * (0.8 - 0.4), 1e-6);
  EXPECT_NEAR(hl.colour.z, 0.6 + 0.5 * (0.0 - 0.6), 1e-6);
  const ProjectedSplat added = project_splat(g[0], 0, 0, cam, false, {EditTintKind::Added, 2});
  const double s = kEditTintStrength * 6.0 / 8.0;
  EXPECT_NEAR(added.colour.y, plain.colour.y + s * (1.0 - plain.colour.y), 1e-12);
  EXPECT_EQ(project_splat(g[0], 0, 0, cam, false, {EditTintKind::Replaced, 8}).colour, plain.colour);
  const ProjectedSplat removed = project_splat(g[0], 0, 0, cam, false, {EditTintKind::Removed, 6});
  EXPECT_NEAR(removed.opacity, 0.5 * 2.0 / 8.0, 1e-15);
  EXPECT_NEAR(removed.colour.x, plain.colour.x + kEditTintStrength * (1.0 - plain.colour.x), 1e-12);
  EXPECT_EQ(project_splat(g[0], 0, 0, cam, false, {EditTintKind::Removed, 8}).cull, SplatCull::Removed);

  // Through the rasterizer: highlight by object id, tint per slot.
  const std::vector<ObjectId> set = {ObjectId{7}};
  ReferenceOptions o;
  o.highlight_objects = set;
  auto im = render_reference(g, {}, 0, cam, o);
  ASSERT_TRUE(im);
  EXPECT_NEAR(rgb_at(*im, 32, 32).x, 0.5 * hl.colour.x, 1e-12);
  const std::vector<EditTintState> tints = {{EditTintKind::Removed, 9}};
  o = {};
  o.edit_tints = tints;
  auto gone = render_reference(g, {}, 0, cam, o);
  ASSERT_TRUE(gone);
  EXPECT_EQ(gone->stats.removed_faded, 1u);
  EXPECT_EQ(rgb_at(*gone, 32, 32), glm::dvec3(0.0));
}

TEST(ReferenceRasterizer, RowSubsetEqualsTheFullImageOnThoseRows) {
  std::vector<Gaussian> g;
  for (int k = 0; k < 20; ++k)
    g.push_back(iso({0.1f * float(k - 10), 0.07f * float(k % 7 - 3), 3.0f + 0.2f * float(k)}, 0.1f,
                    {0.3f * float(k % 3), 0.5f, -0.5f}, 1.0f));
  auto full = render_reference(g, {}, 0, test_camera());
  ReferenceOptions o;
  o.row_begin = 20;
  o.row_end = 37;
  o.threads = 2;
  auto part = render_reference(g, {}, 0, test_camera(), o);
  ASSERT_TRUE(full && part);
  for (std::size_t i = 20 * 64 * 3; i < 37 * 64 * 3; ++i) ASSERT_EQ(full->rgb[i], part->rgb[i]) << i;
  auto diff = compare_images(full->rgba8, part->rgba8, 20, 37);
  ASSERT_TRUE(diff);
  EXPECT_TRUE(std::isinf(diff->psnr_db));
  EXPECT_EQ(full->stats.tile_pairs, part->stats.tile_pairs);
  o = {};
  o.threads = 3;
  auto threaded = render_reference(g, {}, 0, test_camera(), o);
  ASSERT_TRUE(threaded);
  EXPECT_EQ(threaded->rgb, full->rgb);
}

TEST(ReferenceRasterizer, StereoEyesShiftAlongCameraX) {
  Camera centre = test_camera();
  centre.world_to_camera[3][1] = 0.5;  // some non-trivial pose
  const Gaussian g = iso({0.0f, 0.0f, 5.0f}, 0.05f, {1.0f, 1.0f, 1.0f});
  const double ipd = 0.064;
  const ProjectedSplat c = project_splat(g, 0, 0, centre);
  const ProjectedSplat l = project_splat(g, 0, 0, stereo_eye_camera(centre, ipd, Eye::Left));
  const ProjectedSplat r = project_splat(g, 0, 0, stereo_eye_camera(centre, ipd, Eye::Right));
  // The left eye sits at -ipd/2 along x, so the point appears +ipd/2 to its right.
  EXPECT_NEAR(l.u - c.u, 100.0 * (ipd / 2) / 5.0, 1e-9);
  EXPECT_NEAR(r.u - c.u, -100.0 * (ipd / 2) / 5.0, 1e-9);
  EXPECT_EQ(l.v, c.v);
}

TEST(ImageMetrics, PsnrAndMaxError) {
  ImageRGBA8 a{4, 2, std::vector<std::uint8_t>(32, 100)};
  ImageRGBA8 b = a;
  auto same = compare_images(a, b);
  ASSERT_TRUE(same);
  EXPECT_TRUE(std::isinf(same->psnr_db));
  EXPECT_EQ(same->max_abs_error, 0);
  b.pixels[5] = 103;   // pixel 1, green: error 3
  b.pixels[3] = 0;     // alpha is ignored
  auto d = compare_images(a, b);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->max_abs_error, 3);
  EXPECT_EQ(d->pixels_differing, 1u);
  EXPECT_NEAR(d->mse, 9.0 / 24.0, 1e-15);
  EXPECT_NEAR(d->psnr_db, 10.0 * std::log10(255.0 * 255.0 / (9.0 / 24.0)), 1e-12);
  auto top = compare_images(a, b, 1, 2);  // row 1 only: equal
  ASSERT_TRUE(top);
  EXPECT_EQ(top->max_abs_error, 0);
  ImageRGBA8 c{2, 4, std::vector<std::uint8_t>(32, 100)};
  auto bad = compare_images(a, c);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.message().find("4x2"), std::string::npos);
  ImageRGBA8 broken{4, 2, std::vector<std::uint8_t>(31, 0)};
  EXPECT_FALSE(compare_images(a, broken));
}

}  // namespace
}  // namespace gauss::render
