// The LoD merge rule (lod_merge.h) and the symmetric 3x3 eigen solver it rests on: moments exact
// on hand-made pairs, degenerate children never poison a parent, eigen-decompositions that
// reconstruct their matrix on diagonal, rotated, repeated and near-singular spectra.
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include <glm/gtc/quaternion.hpp>
#include <glm/matrix.hpp>

#include "gauss/engine/lod_merge.h"
#include "gauss/engine/sym_eigen3.h"

namespace gauss {
namespace {

double max_abs(const glm::dmat3& m) {
  double v = 0.0;
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) v = std::max(v, std::abs(m[c][r]));
  return v;
}

// Relative Frobenius-style error of B against A (max entry norm).
double rel_error(const glm::dmat3& a, const glm::dmat3& b) {
  const double scale = max_abs(a);
  return scale == 0.0 ? max_abs(b) : max_abs(a - b) / scale;
}

glm::dmat3 reconstruct(const SymEigen3& e) {
  glm::dmat3 d(0.0);
  for (int k = 0; k < 3; ++k) d[k][k] = e.values[k];
  return e.vectors * d * glm::transpose(e.vectors);
}

glm::dmat3 rotation(double angle, glm::dvec3 axis) {
  return glm::mat3_cast(glm::angleAxis(angle, glm::normalize(axis)));
}

void expect_proper_orthonormal(const SymEigen3& e) {
  const glm::dmat3 i = glm::transpose(e.vectors) * e.vectors;
  EXPECT_LT(max_abs(i - glm::dmat3(1.0)), 1e-12);
  EXPECT_NEAR(glm::determinant(e.vectors), 1.0, 1e-12);
  EXPECT_LE(e.sweeps, kSymEigen3MaxSweeps);
}

TEST(SymEigen3, Diagonal) {
  glm::dmat3 a(0.0);
  a[0][0] = 2.0;
  a[1][1] = 5.0;
  a[2][2] = -1.0;
  const SymEigen3 e = sym_eigen3(a);
  EXPECT_EQ(e.values, glm::dvec3(5.0, 2.0, -1.0));
  expect_proper_orthonormal(e);
  EXPECT_LT(rel_error(a, reconstruct(e)), 1e-15);
}

TEST(SymEigen3, Rotated) {
  const glm::dvec3 axes[] = {{1, 2, 3}, {-1, 0.5, 0.1}, {0, 0, 1}, {1, 1, 1}};
  for (const glm::dvec3& axis : axes) {
    for (double angle : {0.1, 0.7, 2.0, 3.1}) {
      const glm::dmat3 r = rotation(angle, axis);
      glm::dmat3 d(0.0);
      d[0][0] = 3.0;
      d[1][1] = 0.5;
      d[2][2] = 1.25;
      const glm::dmat3 a = r * d * glm::transpose(r);
      const SymEigen3 e = sym_eigen3(a);
      EXPECT_NEAR(e.values[0], 3.0, 1e-13);
      EXPECT_NEAR(e.values[1], 1.25, 1e-13);
      EXPECT_NEAR(e.values[2], 0.5, 1e-13);
      expect_proper_orthonormal(e);
      EXPECT_LT(rel_error(a, reconstruct(e)), 1e-5);
      EXPECT_LT(rel_error(a, reconstruct(e)), 1e-13);  // what Jacobi actually reaches
    }
  }
}

TEST(SymEigen3, RepeatedEigenvalues) {
  const glm::dmat3 r = rotation(0.9, {0.3, -1.0, 0.4});
  for (const glm::dvec3 spectrum : {glm::dvec3(2, 2, 1), glm::dvec3(4, 1, 1), glm::dvec3(7, 7, 7)}) {
    glm::dmat3 d(0.0);
    for (int k = 0; k < 3; ++k) d[k][k] = spectrum[k];
    const glm::dmat3 a = r * d * glm::transpose(r);
    const SymEigen3 e = sym_eigen3(a);
    EXPECT_NEAR(e.values[0], spectrum[0], 1e-13);
    EXPECT_NEAR(e.values[1], spectrum[1], 1e-13);
    EXPECT_NEAR(e.values[2], spectrum[2], 1e-13);
    expect_proper_orthonormal(e);
    EXPECT_LT(rel_error(a, reconstruct(e)), 1e-5);
  }
}

TEST(SymEigen3, NearSingularAndFlat) {
  // A 3DGS surface Gaussian: 10 cm wide, 10 um thick (variance ratio 1e-8), and harsher.
  const glm::dmat3 r = rotation(1.3, {2.0, -0.7, 0.2});
  for (const glm::dvec3 spectrum : {glm::dvec3(1e-2, 4e-3, 1e-10), glm::dvec3(1.0, 1e-6, 1e-14),
                                    glm::dvec3(1.0, 0.0, 0.0), glm::dvec3(1e-60, 1e-61, 1e-70)}) {
    glm::dmat3 d(0.0);
    for (int k = 0; k < 3; ++k) d[k][k] = spectrum[k];
    const glm::dmat3 a = r * d * glm::transpose(r);
    const SymEigen3 e = sym_eigen3(a);
    expect_proper_orthonormal(e);
    EXPECT_LT(rel_error(a, reconstruct(e)), 1e-5) << spectrum[0] << " " << spectrum[1] << " " << spectrum[2];
    EXPECT_NEAR(e.values[0], spectrum[0], 1e-12 * spectrum[0]);
    // The small eigenvalues are accurate to rounding of the largest (absolute, ~eps |A|).
    EXPECT_NEAR(e.values[2], spectrum[2], 1e-14 * spectrum[0]);
  }
}

TEST(SymEigen3, ZeroMatrix) {
  const SymEigen3 e = sym_eigen3(glm::dmat3(0.0));
  EXPECT_EQ(e.values, glm::dvec3(0.0));
  EXPECT_EQ(e.sweeps, 0);
  expect_proper_orthonormal(e);
}

TEST(SymEigen3, LanesGiveTheBitsOfSingleCalls) {
  // Side by side, every matrix is decomposed as it is alone, whatever its neighbours need:
  // a zero matrix (no sweep) beside one that takes the most sweeps, spectra from 1e-70 to
  // 1e300, repeated and flat; and a count that is no multiple of the lanes.
  std::vector<glm::dmat3> in;
  const glm::dvec3 spectra[] = {{3.0, 0.5, 1.25},    {2, 2, 1},         {7, 7, 7},         {1e-2, 4e-3, 1e-10},
                                {1.0, 0.0, 0.0},     {1e-60, 1e-61, 1e-70}, {1e300, 1.0, 1e-3}, {0, 0, 0}};
  for (int i = 0; i < 4 * kSymEigen3Lanes + 3; ++i) {
    const glm::dvec3 s = spectra[std::size_t(i) % std::size(spectra)];
    glm::dmat3 d(0.0);
    for (int k = 0; k < 3; ++k) d[k][k] = s[k];
    const glm::dmat3 r = rotation(0.3 + 0.37 * i, {1.0 + i, -0.5, 0.25 * i});
    in.push_back(i % 5 == 4 ? d : r * d * glm::transpose(r));
  }
  std::vector<SymEigen3> out(in.size());
  sym_eigen3_lanes(in, out);
  int sweeps_seen = 0;
  for (std::size_t i = 0; i < in.size(); ++i) {
    const SymEigen3 alone = sym_eigen3(in[i]);
    EXPECT_EQ(out[i].values, alone.values) << "matrix " << i;
    EXPECT_EQ(out[i].vectors, alone.vectors) << "matrix " << i;
    EXPECT_EQ(out[i].sweeps, alone.sweeps) << "matrix " << i;
    sweeps_seen |= 1 << std::min(alone.sweeps, 8);
  }
  // The batch did hold lanes that stopped at different sweeps.
  EXPECT_GE(std::popcount(unsigned(sweeps_seen)), 3);
}

Gaussian make(glm::vec3 position, glm::vec3 scale, float opacity, glm::vec3 dc = glm::vec3(0.0f)) {
  Gaussian g;
  g.position = position;
  g.log_scale = glm::log(scale);
  g.opacity_logit = std::log(opacity / (1.0f - opacity));
  g.sh_dc = dc;
  return g;
}

double opacity_of(const Gaussian& g) { return 1.0 / (1.0 + std::exp(-double(g.opacity_logit))); }

TEST(LodMerge, TwoIdenticalKeepMeanAndCovarianceAndCompositeOpacity) {
  Gaussian a = make({1.0f, 2.0f, 3.0f}, {0.3f, 0.1f, 0.02f}, 0.6f, {0.2f, -0.1f, 0.5f});
  a.rotation = glm::normalize(glm::vec4(0.9f, 0.2f, -0.3f, 0.1f));
  const Gaussian pair[2] = {a, a};
  const auto m = merge_gaussians(pair, 0);
  ASSERT_TRUE(m.ok()) << m.message();
  EXPECT_NEAR(glm::length(glm::dvec3(m->position - a.position)), 0.0, 1e-6);
  EXPECT_LT(rel_error(gaussian_covariance(a), gaussian_covariance(*m)), 1e-5);
  // Optical depth is conserved: two coincident copies composite like alpha blending does.
  EXPECT_NEAR(opacity_of(*m), 1.0 - 0.4 * 0.4, 1e-6);
  EXPECT_NEAR(m->sh_dc.x, 0.2f, 1e-6);
  EXPECT_NEAR(m->sh_dc.z, 0.5f, 1e-6);
}

TEST(LodMerge, SingleChildIsItself) {
  Gaussian a = make({-4.0f, 0.5f, 7.0f}, {0.05f, 0.2f, 0.001f}, 0.9f);
  a.rotation = glm::normalize(glm::vec4(0.1f, 0.7f, 0.2f, -0.6f));
  const auto m = merge_gaussians(std::span<const Gaussian>(&a, 1), 0);
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->position, a.position);
  EXPECT_LT(rel_error(gaussian_covariance(a), gaussian_covariance(*m)), 1e-5);
  EXPECT_NEAR(opacity_of(*m), 0.9, 1e-6);
}

TEST(LodMerge, SeparatedIsotropicPairFollowsTheLawOfTotalVariance) {
  // Equal weights, means at x = -/+ d: mean 0, covariance s^2 I + diag(d^2, 0, 0).
  const float s = 0.1f, d = 0.5f;
  const Gaussian pair[2] = {make({-d, 0, 0}, glm::vec3(s), 0.5f), make({d, 0, 0}, glm::vec3(s), 0.5f)};
  // The exact moment match (spread 1), then the default record, whose centres' spread d^2 is
  // widened by spread^2 while the children's own s^2 stays.
  for (const double k : {1.0, LodMergeConfig{}.spread}) {
    LodMergeConfig config;
    config.spread = k;
    const auto m = merge_gaussians(pair, 0, config);
    ASSERT_TRUE(m.ok());
    EXPECT_NEAR(glm::length(glm::dvec3(m->position)), 0.0, 1e-7);
    glm::dmat3 expect(double(s) * s);
    expect[0][0] += k * k * double(d) * d;
    EXPECT_LT(rel_error(expect, gaussian_covariance(*m)), 1e-5) << "spread " << k;
    // Opacity: t = sum t_i A_i / A with A = sqrt(s^2 + k^2 d^2) * s: the optical mass is kept.
    const double t_child = -std::log(0.5), area_child = double(s) * s;
    const double area = std::sqrt(double(s) * s + k * k * double(d) * d) * s;
    EXPECT_NEAR(opacity_of(*m), 1.0 - std::exp(-2.0 * t_child * area_child / area), 1e-6) << "spread " << k;
  }
}

TEST(LodMerge, SpreadLeavesCoincidentChildrenAsTheyAre) {
  // Two copies at one place: no spread of centres to widen, so any spread gives the child's shape.
  const Gaussian one = make({1, 2, 3}, {0.3f, 0.1f, 0.02f}, 0.4f);
  const Gaussian pair[2] = {one, one};
  for (const double k : {1.0, 1.7, 3.0}) {
    LodMergeConfig config;
    config.spread = k;
    const auto m = merge_gaussians(pair, 0, config);
    ASSERT_TRUE(m.ok());
    EXPECT_LT(rel_error(gaussian_covariance(one), gaussian_covariance(*m)), 1e-5) << "spread " << k;
  }
}

TEST(LodMerge, WeightsAreOpacityTimesAreaAndColoursFollow) {
  // a: opacity 0.8, area 0.1 * 0.1 = 0.01 -> w 0.008. b: opacity 0.25, area 0.4 * 0.2 = 0.08 -> w 0.02.
  Gaussian a = make({0, 0, 0}, {0.1f, 0.1f, 0.01f}, 0.8f, {1.0f, 0.0f, 0.0f});
  Gaussian b = make({1, 2, 0}, {0.4f, 0.2f, 0.05f}, 0.25f, {0.0f, 1.0f, 0.0f});
  a.sh_rest[0] = glm::vec3(1.0f, 2.0f, 3.0f);
  b.sh_rest[2] = glm::vec3(-1.0f);
  const double wa = 0.8 * 0.01, wb = 0.25 * 0.08, w = wa + wb;
  const Gaussian pair[2] = {a, b};
  const auto m = merge_gaussians(pair, 1);
  ASSERT_TRUE(m.ok());
  EXPECT_NEAR(m->position.x, wb / w, 1e-6);
  EXPECT_NEAR(m->position.y, 2.0 * wb / w, 1e-6);
  EXPECT_NEAR(m->sh_dc.x, wa / w, 1e-6);
  EXPECT_NEAR(m->sh_dc.y, wb / w, 1e-6);
  EXPECT_NEAR(m->sh_rest[0].z, 3.0 * wa / w, 1e-6);
  EXPECT_NEAR(m->sh_rest[2].x, -wb / w, 1e-6);
  // Degree 1 has 3 rest coefficients: nothing beyond is written.
  EXPECT_EQ(m->sh_rest[3], glm::vec3(0.0f));
}

TEST(LodMerge, MomentsAreAssociative) {
  std::vector<Gaussian> g;
  for (int i = 0; i < 5; ++i) {
    Gaussian x = make({float(i), float(i * i) * 0.1f, -float(i)}, {0.1f + 0.05f * i, 0.02f, 0.3f}, 0.2f + 0.1f * i,
                      {0.1f * i, 0.0f, -0.2f});
    x.rotation = glm::normalize(glm::vec4(1.0f, 0.1f * i, 0.0f, 0.3f));
    g.push_back(x);
  }
  LodMoments leaf[5], left, right, both, flat;
  glm::dvec3 rest[1];
  for (int i = 0; i < 5; ++i) ASSERT_EQ(leaf_moments(g[std::size_t(i)], 0, {}, leaf[i], rest), LodLeafStatus::Usable);
  combine_moments(std::span<const LodMoments>(leaf, 2), {}, 0, left, {});
  combine_moments(std::span<const LodMoments>(leaf + 2, 3), {}, 0, right, {});
  const LodMoments halves[2] = {left, right};
  combine_moments(halves, {}, 0, both, {});
  combine_moments(leaf, {}, 0, flat, {});
  EXPECT_NEAR(both.weight, flat.weight, 1e-14 * flat.weight);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(both.mean[a], flat.mean[a], 1e-12);
  for (int e = 0; e < 6; ++e) EXPECT_NEAR(both.cov[e], flat.cov[e], 1e-12);
  EXPECT_NEAR(both.optical_mass, flat.optical_mass, 1e-14);
}

TEST(LodMerge, ObjectIsCommonElseNoneAndSupportSaturates) {
  Gaussian a = make({0, 0, 0}, glm::vec3(0.1f), 0.5f), b = make({1, 0, 0}, glm::vec3(0.1f), 0.5f);
  a.object = b.object = ObjectId{4};
  a.support = 0xFFFFFFF0u;
  b.support = 100;
  Gaussian pair[2] = {a, b};
  auto m = merge_gaussians(pair, 0);
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->object, ObjectId{4});
  EXPECT_EQ(m->support, 0xFFFFFFFFu);
  pair[1].object = ObjectId{5};
  m = merge_gaussians(pair, 0);
  EXPECT_EQ(m->object, kNoObject);
}

bool all_finite(const Gaussian& g) {
  bool ok = finite3(g.position) && finite3(g.log_scale) && finite3(g.sh_dc) && std::isfinite(g.opacity_logit);
  for (int k = 0; k < 4; ++k) ok = ok && std::isfinite(g.rotation[k]);
  for (const glm::vec3& r : g.sh_rest) ok = ok && finite3(r);
  return ok;
}

TEST(LodMerge, DegenerateChildrenNeverPoisonAParent) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const Gaussian normal = make({1, 1, 1}, glm::vec3(0.05f), 0.7f, {0.3f, 0.3f, 0.3f});
  Gaussian nan_pos = normal;
  nan_pos.position.y = nan;
  Gaussian inf_colour = normal;
  inf_colour.sh_dc.x = inf;
  Gaussian zero_opacity = normal;
  zero_opacity.opacity_logit = -1e4f;  // sigmoid is 0 in double
  Gaussian huge = make({100, 0, 0}, glm::vec3(1e30f), 0.9f);
  Gaussian tiny = make({-3, 0, 0}, glm::vec3(1e-30f), 0.9f);
  Gaussian zero_rotation = normal;
  zero_rotation.rotation = glm::vec4(0.0f);

  LodMoments m;
  glm::dvec3 rest[1];
  EXPECT_EQ(leaf_moments(nan_pos, 0, {}, m, rest), LodLeafStatus::NonFinite);
  EXPECT_EQ(leaf_moments(inf_colour, 0, {}, m, rest), LodLeafStatus::NonFinite);
  EXPECT_EQ(leaf_moments(zero_rotation, 0, {}, m, rest), LodLeafStatus::NonFinite);
  EXPECT_EQ(leaf_moments(zero_opacity, 0, {}, m, rest), LodLeafStatus::ZeroWeight);
  EXPECT_EQ(leaf_moments(huge, 0, {}, m, rest), LodLeafStatus::TooLarge);
  EXPECT_EQ(leaf_moments(tiny, 0, {}, m, rest), LodLeafStatus::Usable);

  // With one good child, the bad ones have no say: the parent is the good one (the 1e-30 one
  // weighs 1e-60 against 2.5e-3).
  const Gaussian mix[] = {nan_pos, normal, zero_opacity, huge, inf_colour, tiny, zero_rotation};
  const auto p = merge_gaussians(mix, 0);
  ASSERT_TRUE(p.ok());
  EXPECT_TRUE(all_finite(*p));
  EXPECT_NEAR(glm::length(glm::dvec3(p->position - normal.position)), 0.0, 1e-6);
  EXPECT_NEAR(opacity_of(*p), 0.7, 1e-5);

  // Only tiny children: still a finite parent (the spread dominates their 1e-30 scales).
  const Gaussian tinies[] = {tiny, make({-2, 0, 0}, glm::vec3(1e-30f), 0.9f)};
  const auto t = merge_gaussians(tinies, 0);
  ASSERT_TRUE(t.ok());
  EXPECT_TRUE(all_finite(*t));
  // Coincident tiny children: the covariance is 1e-60, its log-scales still finite.
  const Gaussian coincident[] = {tiny, tiny};
  const auto c = merge_gaussians(coincident, 0);
  ASSERT_TRUE(c.ok());
  EXPECT_TRUE(all_finite(*c));
  EXPECT_NEAR(c->log_scale.x, std::log(1e-30), 1e-3);

  // Nothing usable: no parent, said so.
  const Gaussian bad[] = {nan_pos, zero_opacity, huge};
  const auto none = merge_gaussians(bad, 0);
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.message().find("none of the 3 children"), std::string::npos);
}

}  // namespace
}  // namespace gauss
