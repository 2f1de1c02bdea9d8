// Numerical-stability cases of the renderer spec, on the CPU reference: every case renders
// finite, deterministic output (rendered twice, bit-identical) with the expected qualitative
// result. The GPU tests compare against these same scenes. CPU only.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/engine/quaternion.h"
#include "gauss/render/reference_rasterizer.h"

namespace gauss::render {
namespace {

Camera cam64() {
  Camera c;
  c.width = c.height = 64;
  c.fx = c.fy = 100.0;
  c.cx = c.cy = 32.5;  // the optical axis hits the sample point of pixel (32, 32)
  return c;
}

Gaussian make(glm::vec3 pos, glm::vec3 log_scale, glm::vec3 dc, float logit = 0.0f) {
  Gaussian g;
  g.position = pos;
  g.log_scale = log_scale;
  g.sh_dc = dc;
  g.opacity_logit = logit;
  return g;
}

float dc_of_colour(double colour) { return float((colour - 0.5) / kShC0); }
const glm::vec3 kWhite{dc_of_colour(1.0)};

// Renders twice, checks both runs are bit-identical and every value finite.
ReferenceImage render_checked(const std::vector<Gaussian>& g, int degree = 0, const Camera& cam = cam64(),
                              const ReferenceOptions& o = {}) {
  auto a = render_reference(g, {}, degree, cam, o);
  auto b = render_reference(g, {}, degree, cam, o);
  EXPECT_TRUE(a && b);
  if (!a || !b) return {};
  EXPECT_EQ(a->rgb, b->rgb);
  EXPECT_EQ(a->rgba8.pixels, b->rgba8.pixels);
  for (double v : a->rgb) EXPECT_TRUE(std::isfinite(v));
  for (double t : a->transmittance) EXPECT_TRUE(std::isfinite(t) && t >= 0.0 && t <= 1.0);
  return std::move(*a);
}

double red(const ReferenceImage& im, std::uint32_t row, std::uint32_t col) { return im.rgb[(row * im.width + col) * 3]; }
double trans(const ReferenceImage& im, std::uint32_t row, std::uint32_t col) { return im.transmittance[row * im.width + col]; }

TEST(ReferenceStability, TinyLogScaleRendersAsTheDilatedPoint) {
  // log-scale -16: the 3D footprint vanishes and only the 0.3 px^2 dilation is left.
  const auto im = render_checked({make({0.0f, 0.0f, 5.0f}, glm::vec3(-16.0f), kWhite, 3.0f)});
  const ProjectedSplat s = project_splat(make({0.0f, 0.0f, 5.0f}, glm::vec3(-16.0f), kWhite, 3.0f), 0, 0, cam64());
  EXPECT_NEAR(s.cov2d.x, kDilation, 1e-9);
  EXPECT_EQ(s.radius, 3.0);  // ceil(3 sqrt(0.3 + sqrt(0.1)))
  EXPECT_NEAR(red(im, 32, 32), sigmoid(3.0), 1e-6);  // power 0 at the centre pixel
  EXPECT_LT(red(im, 32, 34), 1.0 / 255.0);            // two pixels away: below the alpha floor
}

TEST(ReferenceStability, HugeLogScaleCoversTheViewUniformly) {
  // log-scale +7: a 1.1 km Gaussian 5 m away. Every pixel sees alpha ~= opacity.
  const auto im = render_checked({make({0.0f, 0.0f, 5.0f}, glm::vec3(7.0f), kWhite, 0.0f)});
  EXPECT_EQ(im.stats.visible, 1u);
  EXPECT_EQ(im.stats.tile_pairs, 16u);  // all 4x4 tiles
  for (std::uint32_t i = 0; i < 64; i += 7)
    for (std::uint32_t j = 0; j < 64; j += 7) EXPECT_NEAR(red(im, i, j), 0.5, 1e-5);
}

TEST(ReferenceStability, Anisotropy1e6IsAThinLine) {
  // 1 m along x, 1 um across: a horizontal line through the centre row.
  const auto im = render_checked({make({0.0f, 0.0f, 5.0f}, {0.0f, std::log(1e-6f), std::log(1e-6f)}, kWhite, 3.0f)});
  EXPECT_GT(red(im, 32, 10), 0.5);
  EXPECT_GT(red(im, 32, 54), 0.5);
  EXPECT_EQ(red(im, 40, 32), 0.0);  // 8 rows off the line: nothing (not even evaluated tiles count)
  // Rotated 90 degrees about z (unit quaternion (cos 45, 0, 0, sin 45)): a vertical line.
  Gaussian g = make({0.0f, 0.0f, 5.0f}, {0.0f, std::log(1e-6f), std::log(1e-6f)}, kWhite, 3.0f);
  g.rotation = {std::sqrt(0.5f), 0.0f, 0.0f, std::sqrt(0.5f)};
  const auto v = render_checked({g});
  EXPECT_GT(red(v, 10, 32), 0.5);
  EXPECT_LT(red(v, 32, 10), 1.0 / 255.0);
}

TEST(ReferenceStability, ZeroAndTinyQuaternionsNormaliseAtLoad) {
  const glm::vec3 aniso{0.0f, -3.0f, -3.0f};
  Gaussian zero = make({0.0f, 0.0f, 5.0f}, aniso, kWhite, 1.0f);
  zero.rotation = glm::vec4(0.0f);
  EXPECT_EQ(normalize_quaternion(zero.rotation), QuaternionNormalization::ZeroReplacedByIdentity);
  Gaussian identity = make({0.0f, 0.0f, 5.0f}, aniso, kWhite, 1.0f);
  EXPECT_EQ(render_checked({zero}).rgb, render_checked({identity}).rgb);

  Gaussian tiny = make({0.0f, 0.0f, 5.0f}, aniso, kWhite, 1.0f);
  tiny.rotation = {1e-20f, 0.0f, 0.0f, 1e-20f};  // 90 degrees about z, length 1.4e-20
  EXPECT_EQ(normalize_quaternion(tiny.rotation), QuaternionNormalization::Normalized);
  Gaussian unit = make({0.0f, 0.0f, 5.0f}, aniso, kWhite, 1.0f);
  unit.rotation = {std::sqrt(0.5f), 0.0f, 0.0f, std::sqrt(0.5f)};
  const auto a = render_checked({tiny});
  const auto b = render_checked({unit});
  EXPECT_EQ(a.rgba8.pixels, b.rgba8.pixels);
  EXPECT_NE(render_checked({identity}).rgba8.pixels, a.rgba8.pixels);  // the rotation matters
}

TEST(ReferenceStability, OpacityLogitsPlusMinusTwenty) {
  const auto opaque = render_checked({make({0.0f, 0.0f, 5.0f}, glm::vec3(-3.0f), kWhite, 20.0f)});
  EXPECT_NEAR(red(opaque, 32, 32), kAlphaMax, 1e-7);  // alpha capped at 0.99
  EXPECT_NEAR(trans(opaque, 32, 32), 1.0 - kAlphaMax, 1e-15);
  ReferenceOptions o;
  o.clear_colour = glm::dvec3(0.25);
  const auto clear = render_checked({make({0.0f, 0.0f, 5.0f}, glm::vec3(-3.0f), kWhite, -20.0f)}, 0, cam64(), o);
  for (std::size_t px = 0; px < 64 * 64; ++px) ASSERT_EQ(clear.transmittance[px], 1.0);  // below 1/255 everywhere
  EXPECT_EQ(red(clear, 32, 32), 0.25);
}

TEST(ReferenceStability, StraddlingTheNearCullAndBehindTheCamera) {
  // Centres decide: 0.1 m (big enough to reach far past the near plane) and -3 m are culled;
  // 0.25 m is drawn even though most of it is behind the near plane.
  std::vector<Gaussian> g = {make({0.0f, 0.0f, 0.1f}, glm::vec3(0.0f), kWhite, 5.0f),
                             make({0.0f, 0.0f, -3.0f}, glm::vec3(1.0f), kWhite, 5.0f)};
  const auto culled = render_checked(g);
  EXPECT_EQ(culled.stats.culled_near, 2u);
  EXPECT_EQ(red(culled, 32, 32), 0.0);
  g.push_back(make({0.0f, 0.0f, 0.25f}, glm::vec3(-1.0f), kWhite, 5.0f));
  const auto drawn = render_checked(g);
  EXPECT_EQ(drawn.stats.visible, 1u);
  EXPECT_GT(red(drawn, 32, 32), 0.9);
  EXPECT_GT(red(drawn, 0, 0), 0.0);  // 0.37 m sigma at 0.25 m: it covers the view
}

TEST(ReferenceStability, HundredKilometresAwayIsAtMostADilatedPoint) {
  const auto im = render_checked({make({0.0f, 0.0f, 1e5f}, glm::vec3(std::log(0.05f)), kWhite, 3.0f)});
  const ProjectedSplat s = project_splat(make({0.0f, 0.0f, 1e5f}, glm::vec3(std::log(0.05f)), kWhite, 3.0f), 0, 0, cam64());
  EXPECT_LE(s.radius, 3.0);
  int lit = 0;
  for (std::size_t px = 0; px < 64 * 64; ++px) lit += im.transmittance[px] < 1.0 ? 1 : 0;
  EXPECT_GT(lit, 0);
  EXPECT_LE(lit, 9);  // the 0.3 px^2 dilation lights at most the centre and its neighbours
}

TEST(ReferenceStability, FiveHundredCoplanarGaussiansBlendInSlotOrder) {
  // All at depth 5 exactly (equal depth keys), each centred on pixel (32, 32): the order is
  // the slot order. Compare with a hand-written sequential blend in that order.
  std::vector<Gaussian> g;
  for (int k = 0; k < 500; ++k) {
    const double c = double((k * 37) % 500) / 499.0;
    g.push_back(make({0.0f, 0.0f, 5.0f}, glm::vec3(-3.0f), {dc_of_colour(c), dc_of_colour(1.0 - c), dc_of_colour(0.5)}, -4.0f));
  }
  const auto im = render_checked(g);
  double C = 0.0, T = 1.0;
  for (int k = 0; k < 500; ++k) {
    const ProjectedSplat s = project_splat(g[std::size_t(k)], std::uint32_t(k), 0, cam64());
    const double alpha = std::min(kAlphaMax, s.opacity);  // power 0 at this pixel
    if (alpha < kAlphaMin) continue;
    if (T * (1.0 - alpha) < kTransmittanceStop) break;
    C += s.colour.x * alpha * T;
    T *= 1.0 - alpha;
  }
  EXPECT_NEAR(red(im, 32, 32), C, 1e-12);
  EXPECT_NEAR(trans(im, 32, 32), T, 1e-12);
  std::vector<Gaussian> reversed(g.rbegin(), g.rend());
  const auto rev = render_checked(reversed);
  EXPECT_GT(std::abs(red(rev, 32, 32) - C), 1e-3);  // a different slot order is a different image
}

TEST(ReferenceStability, TenThousandStackedLayersSaturateWithoutUnderflow) {
  std::vector<Gaussian> g;
  for (int k = 0; k < 10000; ++k)
    g.push_back(make({0.0f, 0.0f, 2.0f + 0.001f * float(k)}, glm::vec3(-2.0f), kWhite, -1.0f));
  const auto im = render_checked(g);
  const double T = trans(im, 32, 32);
  EXPECT_GE(T, kTransmittanceStop);  // the stop rule keeps T from ever underflowing
  EXPECT_LT(T, kTransmittanceStop / (1.0 - sigmoid(-1.0)));
  EXPECT_NEAR(red(im, 32, 32), 1.0 - T, 1e-6);  // saturated white
  EXPECT_EQ(im.stats.visible, 10000u);
}

TEST(ReferenceStability, DepthsFromAMillimetreToAHundredKilometres) {
  std::vector<Gaussian> g;
  // Slot 0 nearest: 1e-3 m (culled), then log-spaced to 1e5 m; colours alternate.
  for (int k = 0; k <= 80; ++k) {
    const float z = std::pow(10.0f, -3.0f + 0.1f * float(k));
    g.push_back(make({0.0f, 0.0f, z}, glm::vec3(std::log(0.02f * z)), k % 2 ? kWhite : glm::vec3(dc_of_colour(0.0)), 4.0f));
  }
  const auto im = render_checked(g);
  EXPECT_EQ(im.stats.culled_near, 24u);  // k = 0..23: 1e-3 .. 10^-0.7 = 0.1995 <= 0.2
  // The nearest drawn one (k = 24, z = 0.25, black) is in front: the pixel is mostly black.
  EXPECT_LT(red(im, 32, 32), 0.05);
}

TEST(ReferenceStability, EqualFloatDepthKeysTieBySlotEvenIfDoublesDiffer) {
  // A camera yawed by 1e-5 rad sees (0.5, 0, 1e5) 5 um deeper than (0, 0, 1e5): different
  // doubles, the same float32 key (its spacing at 1e5 is 7.8 mm). The slot order decides,
  // on both paths, because the key is float32(t.z).
  const double sn = 1e-5, cs = std::sqrt(1.0 - sn * sn);
  Camera cam = cam64();
  cam.world_to_camera[0][0] = cs;
  cam.world_to_camera[2][0] = -sn;
  cam.world_to_camera[0][2] = sn;
  cam.world_to_camera[2][2] = cs;
  const glm::vec3 black{dc_of_colour(0.0)};
  const Gaussian farther = make({0.5f, 0.0f, 1e5f}, glm::vec3(std::log(0.05f)), kWhite, 20.0f);
  const Gaussian nearer = make({0.0f, 0.0f, 1e5f}, glm::vec3(std::log(0.05f)), black, 20.0f);
  const ProjectedSplat a = project_splat(farther, 0, 0, cam);
  const ProjectedSplat b = project_splat(nearer, 1, 0, cam);
  EXPECT_GT(a.view.z, b.view.z);
  EXPECT_EQ(a.depth_key, b.depth_key);
  const auto white_first = render_checked({farther, nearer}, 0, cam);
  const auto black_first = render_checked({nearer, farther}, 0, cam);
  EXPECT_GT(red(white_first, 32, 32), 0.9);
  EXPECT_LT(red(black_first, 32, 32), 0.1);
}

TEST(ReferenceStability, ShColourFarOutsideTheUnitRange) {
  ReferenceOptions o;
  o.clear_colour = glm::dvec3(1.0);
  const auto im = render_checked({make({0.0f, 0.0f, 5.0f}, glm::vec3(-3.0f), {100.0f, -100.0f, 0.0f}, 0.0f)}, 0,
                                 cam64(), o);
  EXPECT_GT(red(im, 32, 32), 1.0);  // unclamped linear value kept
  const std::uint8_t* p = &im.rgba8.pixels[(32 * 64 + 32) * 4];
  EXPECT_EQ(p[0], 255);                              // clamped at output
  EXPECT_EQ(p[1], to_unorm8(0.5));                   // black at alpha 0.5 over white
  EXPECT_EQ(p[2], to_unorm8(0.5 * 0.5 + 0.5));
}

}  // namespace
}  // namespace gauss::render
