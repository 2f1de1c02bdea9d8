// SH evaluation of the reference against the closed-form real spherical harmonics, written
// in spherical coordinates with their normalisation constants, so both the polynomial forms
// and the constants of splat_math.h are checked independently. CPU only.
#include <cmath>
#include <functional>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/engine/scene_up.h"
#include "gauss/render/reference_rasterizer.h"

namespace gauss::render {
namespace {

constexpr double kPi = std::numbers::pi;

// Basis function k (0..15) in the sign convention of computeColorFromSH, for the direction
// (sin t cos p, sin t sin p, cos t).
double closed_form(int k, double t, double p) {
  const double st = std::sin(t), ct = std::cos(t), sp = std::sin(p), cp = std::cos(p);
  switch (k) {
    case 0: return 0.5 * std::sqrt(1.0 / kPi);
    case 1: return -std::sqrt(3.0 / (4.0 * kPi)) * st * sp;
    case 2: return std::sqrt(3.0 / (4.0 * kPi)) * ct;
    case 3: return -std::sqrt(3.0 / (4.0 * kPi)) * st * cp;
    case 4: return 0.5 * std::sqrt(15.0 / kPi) * st * st * sp * cp;
    case 5: return -0.5 * std::sqrt(15.0 / kPi) * st * ct * sp;
    case 6: return 0.25 * std::sqrt(5.0 / kPi) * (3.0 * ct * ct - 1.0);
    case 7: return -0.5 * std::sqrt(15.0 / kPi) * st * ct * cp;
    case 8: return 0.25 * std::sqrt(15.0 / kPi) * st * st * std::cos(2.0 * p);
    case 9: return -0.25 * std::sqrt(35.0 / (2.0 * kPi)) * st * st * st * std::sin(3.0 * p);
    case 10: return 0.5 * std::sqrt(105.0 / kPi) * st * st * ct * sp * cp;
    case 11: return -0.25 * std::sqrt(21.0 / (2.0 * kPi)) * st * sp * (5.0 * ct * ct - 1.0);
    case 12: return 0.25 * std::sqrt(7.0 / kPi) * ct * (5.0 * ct * ct - 3.0);
    case 13: return -0.25 * std::sqrt(21.0 / (2.0 * kPi)) * st * cp * (5.0 * ct * ct - 1.0);
    case 14: return 0.25 * std::sqrt(105.0 / kPi) * ct * st * st * std::cos(2.0 * p);
    case 15: return -0.25 * std::sqrt(35.0 / (2.0 * kPi)) * st * st * st * std::cos(3.0 * p);
    default: return 0.0;
  }
}

int degree_of(int k) { return k == 0 ? 0 : k < 4 ? 1 : k < 9 ? 2 : 3; }

Gaussian with_coefficient(int k, glm::vec3 value) {
  Gaussian g;
  if (k == 0)
    g.sh_dc = value;
  else
    g.sh_rest[std::size_t(k - 1)] = value;
  return g;
}

TEST(ReferenceSh, EveryBasisFunctionMatchesItsClosedForm) {
  const std::vector<std::pair<double, double>> dirs = {{0.3, 0.2}, {1.1, 2.5}, {2.0, -1.3}, {2.9, 4.0}, {1.5708, 0.0}};
  for (int k = 0; k < 16; ++k) {
    for (auto [t, p] : dirs) {
      const glm::dvec3 dir(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t));
      const Gaussian g = with_coefficient(k, {1.0f, -2.0f, 0.5f});
      const glm::dvec3 r = eval_sh(g, 3, dir);
      const double y = closed_form(k, t, p);
      EXPECT_NEAR(r.x, y, 1e-12) << "k=" << k;
      EXPECT_NEAR(r.y, -2.0 * y, 1e-12) << "k=" << k;
      EXPECT_NEAR(r.z, 0.5 * y, 1e-12) << "k=" << k;
    }
  }
}

TEST(ReferenceSh, DegreeLimitsWhichCoefficientsAreRead) {
  const glm::dvec3 dir = glm::normalize(glm::dvec3(0.3, -0.4, 0.8));
  for (int k = 1; k < 16; ++k) {
    const Gaussian g = with_coefficient(k, {1.0f, 1.0f, 1.0f});
    for (int d = 0; d <= 3; ++d) {
      const glm::dvec3 r = eval_sh(g, d, dir);
      if (d < degree_of(k))
        EXPECT_EQ(r.x, 0.0) << "k=" << k << " degree=" << d;
      else
        EXPECT_NE(r.x, 0.0) << "k=" << k << " degree=" << d;
    }
  }
}

TEST(ReferenceSh, ColourUsesTheDirectionFromTheCameraCentre) {
  // Camera rotated 90 degrees about y and moved: the colour depends on the world-space
  // direction p - c only, with c = -W^T w.
  Camera cam;
  cam.width = cam.height = 64;
  cam.fx = cam.fy = 50.0;
  cam.cx = cam.cy = 32.0;
  // Camera centre at (1, 2, 3), looking along world +x: camera z = world x, camera x = world -z.
  glm::dmat3 R(0.0);
  R[2][0] = -1.0;  // row 0 (camera x) = world (0, 0, -1)
  R[1][1] = 1.0;   // row 1 (camera y) = world y
  R[0][2] = 1.0;   // row 2 (camera z) = world x
  const glm::dvec3 centre(1.0, 2.0, 3.0);
  cam.world_to_camera = glm::dmat4(R);
  const glm::dvec3 w = -(R * centre);
  cam.world_to_camera[3] = glm::dvec4(w, 1.0);

  Gaussian g;
  g.position = {6.0f, 2.5f, 3.2f};
  g.log_scale = glm::vec3(-3.0f);
  g.sh_dc = {0.1f, 0.2f, 0.3f};
  for (int k = 0; k < kMaxShRest; ++k) g.sh_rest[std::size_t(k)] = glm::vec3(0.05f * float(k % 5) - 0.1f, 0.03f, -0.02f * float(k));
  for (int d = 0; d <= 3; ++d) {
    const ProjectedSplat s = project_splat(g, 0, d, cam);
    ASSERT_EQ(s.cull, SplatCull::Visible);
    const glm::dvec3 dir = glm::normalize(glm::dvec3(g.position) - centre);
    const glm::dvec3 expected = glm::max(eval_sh(g, d, dir) + 0.5, glm::dvec3(0.0));
    EXPECT_NEAR(s.colour.x, expected.x, 1e-12);
    EXPECT_NEAR(s.colour.y, expected.y, 1e-12);
    EXPECT_NEAR(s.colour.z, expected.z, 1e-12);
    EXPECT_NEAR(s.view.z, 5.0, 1e-6);
  }
}

TEST(ReferenceSh, ColourIsClampedBelowOnlyAtZero) {
  Camera cam;
  cam.width = cam.height = 32;
  cam.fx = cam.fy = 40.0;
  cam.cx = cam.cy = 16.0;
  Gaussian g;
  g.position = {0.0f, 0.0f, 3.0f};
  g.log_scale = glm::vec3(-3.0f);
  g.sh_dc = {100.0f, -100.0f, 0.0f};
  const ProjectedSplat s = project_splat(g, 0, 0, cam);
  EXPECT_NEAR(s.colour.x, kShC0 * 100.0 + 0.5, 1e-9);  // far above 1: kept
  EXPECT_EQ(s.colour.y, 0.0);                           // below 0: clamped
  EXPECT_EQ(s.colour.z, 0.5);
}

// scene_up.h's half turn about x is exact: SH 3 Gaussians turned, seen from a camera turned
// the same way, render the originals' image byte for byte; a sign left out of the SH rest
// (or the rotation left unturned) does not.
TEST(HalfTurnAboutX, TurnedGaussiansFromTheTurnedCameraRenderTheSameImage) {
  Camera cam;
  cam.width = 96;
  cam.height = 72;
  cam.fx = cam.fy = 80.0;
  cam.cx = 48.0;
  cam.cy = 36.0;  // world_to_camera: identity, looking down +z
  std::vector<Gaussian> scene(300);
  std::uint64_t s = 0x5EEDull;
  auto uniform = [&s](double a, double b) {
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    return float(a + (b - a) * double(s >> 11) * 0x1.0p-53);
  };
  for (Gaussian& g : scene) {
    g.position = {uniform(-1.2, 1.2), uniform(-0.9, 0.9), uniform(2.0, 5.0)};
    g.log_scale = {uniform(-3.5, -1.5), uniform(-4.0, -2.0), uniform(-4.5, -2.0)};
    g.rotation = glm::normalize(glm::vec4(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)));
    g.opacity_logit = uniform(-2.0, 2.0);
    g.sh_dc = {uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)};
    for (glm::vec3& c : g.sh_rest) c = {uniform(-0.6, 0.6), uniform(-0.6, 0.6), uniform(-0.6, 0.6)};
  }
  Camera turned_cam = cam;
  turned_cam.world_to_camera = cam.world_to_camera * glm::dmat4(glm::dvec4(1, 0, 0, 0), glm::dvec4(0, -1, 0, 0),
                                                                glm::dvec4(0, 0, -1, 0), glm::dvec4(0, 0, 0, 1));
  auto render = [](const std::vector<Gaussian>& g, const Camera& c) {
    auto image = render_reference(g, {}, 3, c);
    EXPECT_TRUE(image.ok()) << (image.ok() ? "" : image.message());
    return image.ok() ? image->rgba8.pixels : std::vector<std::uint8_t>{};
  };
  const auto original = render(scene, cam);
  std::vector<Gaussian> turned = scene;
  half_turn_about_x(turned);
  EXPECT_EQ(render(turned, turned_cam), original);

  int lit = 0;  // the image is not empty
  for (std::size_t i = 0; i < original.size(); i += 4) lit += original[i] + original[i + 1] + original[i + 2] > 30;
  EXPECT_GT(lit, int(original.size() / 4 / 4));

  for (int k : {0, 4, 9}) {  // one coefficient of each degree with the other sign
    std::vector<Gaussian> wrong = turned;
    for (Gaussian& g : wrong) g.sh_rest[k] *= -1.0f;
    EXPECT_NE(render(wrong, turned_cam), original) << "coefficient " << k + 1;
  }
  std::vector<Gaussian> unrotated = turned;
  for (std::size_t i = 0; i < scene.size(); ++i) unrotated[i].rotation = scene[i].rotation;
  EXPECT_NE(render(unrotated, turned_cam), original);
}

}  // namespace
}  // namespace gauss::render
