#include "gauss/engine/lod_merge.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <glm/matrix.hpp>

#include "gauss/engine/sym_eigen3.h"
#include "lod_leaf_moments.h"

namespace gauss {
namespace {

// Rotation matrix of a quaternion (w, x, y, z) normalised in double; false when it has no
// direction (zero or non-finite length).
bool rotation_matrix(const glm::vec4& q, glm::dmat3& r) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const double n2 = w * w + x * x + y * y + z * z;
  if (!(n2 > 0.0) || !std::isfinite(n2)) return false;
  const double s = 2.0 / n2;  // normalises on the fly: R of q/|q|
  // Columns (GLM is column-major): r[c][row].
  r[0] = glm::dvec3(1.0 - s * (y * y + z * z), s * (x * y + w * z), s * (x * z - w * y));
  r[1] = glm::dvec3(s * (x * y - w * z), 1.0 - s * (x * x + z * z), s * (y * z + w * x));
  r[2] = glm::dvec3(s * (x * z + w * y), s * (y * z - w * x), 1.0 - s * (x * x + y * y));
  return true;
}

// softplus(x) = ln(1 + e^x) = -ln(1 - sigmoid(x)), without overflow for large x.
double softplus(double x) { return x > 30.0 ? x + std::log1p(std::exp(-x)) : std::log1p(std::exp(x)); }

// Unit quaternion (w, x, y, z) of a proper rotation matrix (Shepperd: the largest of the four
// squared components is taken by a square root, the rest from it, so no division by ~0).
glm::dvec4 matrix_quaternion(const glm::dmat3& r) {
  const double m00 = r[0][0], m11 = r[1][1], m22 = r[2][2];
  const double tr = m00 + m11 + m22;
  glm::dvec4 q;  // w, x, y, z
  if (tr >= m00 && tr >= m11 && tr >= m22) {
    const double s = 2.0 * std::sqrt(std::max(1.0 + tr, 0.0));
    q = {0.25 * s, (r[1][2] - r[2][1]) / s, (r[2][0] - r[0][2]) / s, (r[0][1] - r[1][0]) / s};
  } else if (m00 >= m11 && m00 >= m22) {
    const double s = 2.0 * std::sqrt(std::max(1.0 + m00 - m11 - m22, 0.0));
    q = {(r[1][2] - r[2][1]) / s, 0.25 * s, (r[1][0] + r[0][1]) / s, (r[2][0] + r[0][2]) / s};
  } else if (m11 >= m22) {
    const double s = 2.0 * std::sqrt(std::max(1.0 - m00 + m11 - m22, 0.0));
    q = {(r[2][0] - r[0][2]) / s, (r[1][0] + r[0][1]) / s, 0.25 * s, (r[2][1] + r[1][2]) / s};
  } else {
    const double s = 2.0 * std::sqrt(std::max(1.0 - m00 - m11 + m22, 0.0));
    q = {(r[0][1] - r[1][0]) / s, (r[2][0] + r[0][2]) / s, (r[2][1] + r[1][2]) / s, 0.25 * s};
  }
  // One sign for one rotation (q and -q are the same): w >= 0, so equal moments give equal bits.
  if (q[0] < 0.0) q = -q;
  return q / std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
}

}  // namespace

const char* to_string(LodLeafStatus s) {
  switch (s) {
    case LodLeafStatus::Usable: return "usable";
    case LodLeafStatus::NonFinite: return "non-finite field";
    case LodLeafStatus::ZeroWeight: return "zero weight (opacity x area)";
    case LodLeafStatus::TooLarge: return "scale above max_scale";
  }
  return "?";
}

glm::dmat3 gaussian_covariance(const Gaussian& g) {
  glm::dmat3 r(1.0);
  if (!rotation_matrix(g.rotation, r)) r = glm::dmat3(1.0);
  const glm::dvec3 var(std::exp(2.0 * double(g.log_scale.x)), std::exp(2.0 * double(g.log_scale.y)),
                       std::exp(2.0 * double(g.log_scale.z)));
  glm::dmat3 s(0.0);
  s[0][0] = var.x;
  s[1][1] = var.y;
  s[2][2] = var.z;
  return r * s * glm::transpose(r);
}

namespace lod_detail {

LodLeafStatus leaf_moments_of(const LeafFieldRefs& g, int rest_count, const LodMergeConfig& config, LodMoments* out,
                              glm::dvec3* rest_out) {
  if (!finite3(g.position) || !finite3(g.log_scale) || !finite3(g.sh_dc) || !std::isfinite(g.opacity_logit))
    return LodLeafStatus::NonFinite;
  for (int k = 0; k < rest_count; ++k)
    if (!finite3(g.rest[k])) return LodLeafStatus::NonFinite;
  glm::dmat3 r;
  if (!rotation_matrix(g.rotation, r)) return LodLeafStatus::NonFinite;
  if (!out) {
    // Status only (the full build asks it of every input Gaussian): where the answer is
    // plain without the four exponentials below, give it. Scales of at most 1 m are within
    // any max_scale >= 1 (exp(2 ls) <= 1), and scales >= e^-100 with a logit >= -200 weigh
    // >= ~e^-400 > 0 (no underflow). Anything else goes the exact way.
    const float lo = std::min({g.log_scale.x, g.log_scale.y, g.log_scale.z});
    const float hi = std::max({g.log_scale.x, g.log_scale.y, g.log_scale.z});
    if (lo >= -100.0f && hi <= 0.0f && g.opacity_logit >= -200.0f && config.max_scale >= 1.0)
      return LodLeafStatus::Usable;
  }

  const glm::dvec3 var(std::exp(2.0 * double(g.log_scale.x)), std::exp(2.0 * double(g.log_scale.y)),
                       std::exp(2.0 * double(g.log_scale.z)));
  double v[3] = {var.x, var.y, var.z};
  std::sort(v, v + 3, [](double a, double b) { return a > b; });
  if (v[0] > config.max_scale * config.max_scale) return LodLeafStatus::TooLarge;
  const double area = std::sqrt(v[0]) * std::sqrt(v[1]);  // s1 s2 (no overflow of v0 v1)
  const double opacity = 1.0 / (1.0 + std::exp(-double(g.opacity_logit)));
  const double weight = opacity * area;
  if (!(weight > 0.0)) return LodLeafStatus::ZeroWeight;
  if (!out) return LodLeafStatus::Usable;

  out->weight = weight;
  out->mean = glm::dvec3(g.position);
  // S = R diag(var) R^T, entry (a, b) = sum_k r[k][a] r[k][b] var_k (r[k] is column k).
  const int ia[6] = {0, 0, 0, 1, 1, 2}, ib[6] = {0, 1, 2, 1, 2, 2};
  for (int e = 0; e < 6; ++e) {
    double sum = 0.0;
    for (int k = 0; k < 3; ++k) sum += r[k][ia[e]] * r[k][ib[e]] * var[k];
    out->cov[e] = sum;
    out->within[e] = sum;
  }
  out->optical_mass = softplus(g.opacity_logit) * area;
  out->sh_dc = glm::dvec3(g.sh_dc);
  out->support = g.support;
  out->object = g.object;
  for (int k = 0; k < rest_count; ++k) rest_out[k] = glm::dvec3(g.rest[k]);
  return LodLeafStatus::Usable;
}

}  // namespace lod_detail

LodLeafStatus leaf_moments(const Gaussian& g, int sh_degree, const LodMergeConfig& config, LodMoments& out,
                           std::span<glm::dvec3> rest_out) {
  const int rest_count = sh_rest_count(std::clamp(sh_degree, 0, kMaxShDegree));
  const lod_detail::LeafFieldRefs leaf{g.position, g.log_scale, g.rotation, g.opacity_logit,
                                       g.sh_dc,    g.sh_rest.data(), g.object, g.support};
  return lod_detail::leaf_moments_of(leaf, rest_count, config, &out, rest_out.data());
}

void combine_moments(std::span<const LodMoments> children, std::span<const glm::dvec3> children_rest,
                     int rest_count, LodMoments& out, std::span<glm::dvec3> rest_out) {
  // Two passes (mean first, then spread about it): accumulating raw second moments and
  // subtracting m m^T would cancel every digit of a millimetre spread 100 m from the origin.
  double w = 0.0, optical = 0.0;
  glm::dvec3 mean(0.0), dc(0.0);
  std::uint64_t support = 0;
  ObjectId object = children.empty() ? kNoObject : children[0].object;
  for (const LodMoments& c : children) {
    w += c.weight;
    mean += c.weight * c.mean;
    dc += c.weight * c.sh_dc;
    optical += c.optical_mass;
    support = std::min<std::uint64_t>(support + c.support, std::numeric_limits<std::uint32_t>::max());
    if (c.object != object) object = kNoObject;
  }
  mean /= w;
  dc /= w;
  double cov[6] = {}, within[6] = {};
  for (const LodMoments& c : children) {
    const glm::dvec3 d = c.mean - mean;
    const double dd[6] = {d.x * d.x, d.x * d.y, d.x * d.z, d.y * d.y, d.y * d.z, d.z * d.z};
    for (int e = 0; e < 6; ++e) {
      cov[e] += c.weight * (c.cov[e] + dd[e]);
      within[e] += c.weight * c.within[e];
    }
  }
  out.weight = w;
  out.mean = mean;
  for (int e = 0; e < 6; ++e) {
    out.cov[e] = cov[e] / w;
    out.within[e] = within[e] / w;
  }
  out.optical_mass = optical;
  out.sh_dc = dc;
  out.support = support;
  out.object = object;
  for (int k = 0; k < rest_count; ++k) {
    glm::dvec3 acc(0.0);
    for (std::size_t i = 0; i < children.size(); ++i)
      acc += children[i].weight * children_rest[i * std::size_t(rest_count) + std::size_t(k)];
    rest_out[std::size_t(k)] = acc / w;
  }
}

glm::dmat3 moments_covariance(const LodMoments& m, double spread) {
  // cov = within + spread^2 (total - within): the leaves' own shapes as they are, the layout of
  // their centres widened (spread 1: the exact moment match).
  const double k2 = spread * spread;
  double c[6];
  for (int e = 0; e < 6; ++e) c[e] = m.within[e] + k2 * (m.cov[e] - m.within[e]);
  glm::dmat3 cov;
  cov[0] = glm::dvec3(c[0], c[1], c[2]);
  cov[1] = glm::dvec3(c[1], c[3], c[4]);
  cov[2] = glm::dvec3(c[2], c[4], c[5]);
  return cov;
}

void moments_geometry(const LodMoments& m, const SymEigen3& e, Gaussian& g) {
  // The floor keeps ln finite for a (numerically) flat or zero covariance; the absolute floor
  // covers an all-zero matrix (impossible from usable leaves, whose scales are > 0).
  const double floor = std::max(e.values[0] * 1e-12, std::numeric_limits<double>::min());
  double log_scale[3];
  for (int k = 0; k < 3; ++k) log_scale[k] = 0.5 * std::log(std::max(e.values[k], floor));

  g.position = glm::vec3(m.mean);
  g.log_scale = glm::vec3(float(log_scale[0]), float(log_scale[1]), float(log_scale[2]));
  g.rotation = glm::vec4(matrix_quaternion(e.vectors));
  // Values are descending, so the two widest axes are 0 and 1.
  const double area = std::exp(log_scale[0] + log_scale[1]);
  const double t = m.optical_mass / area;
  // logit(1 - e^-t) = ln(e^t - 1); for large t that is t + ln(1 - e^-t) (no overflow).
  const double logit = t > 30.0 ? t + std::log1p(-std::exp(-t)) : std::log(std::expm1(t));
  g.opacity_logit = float(std::isnan(logit) ? -60.0 : std::clamp(logit, -60.0, 60.0));
}

Gaussian moments_to_gaussian(const LodMoments& m, std::span<const glm::dvec3> rest, int rest_count, double spread) {
  Gaussian g;
  moments_geometry(m, sym_eigen3(moments_covariance(m, spread)), g);
  moments_appearance(m, rest, rest_count, g);
  return g;
}

void moments_appearance(const LodMoments& m, std::span<const glm::dvec3> rest, int rest_count, Gaussian& g) {
  g.sh_dc = glm::vec3(m.sh_dc);
  for (int k = 0; k < rest_count; ++k) g.sh_rest[std::size_t(k)] = glm::vec3(rest[std::size_t(k)]);
  g.object = m.object;
  g.support = std::uint32_t(std::min<std::uint64_t>(m.support, std::numeric_limits<std::uint32_t>::max()));
  g.carrier = false;
}

bool same_geometry(const LodMoments& a, const LodMoments& b) {
  auto bits = [](double x) { return std::bit_cast<std::uint64_t>(x); };
  bool same = bits(a.optical_mass) == bits(b.optical_mass);
  for (int k = 0; k < 3; ++k) same = same && bits(a.mean[k]) == bits(b.mean[k]);
  for (int e = 0; e < 6; ++e) same = same && bits(a.cov[e]) == bits(b.cov[e]) && bits(a.within[e]) == bits(b.within[e]);
  return same;
}

Expected<Gaussian> merge_gaussians(std::span<const Gaussian> children, int sh_degree,
                                   const LodMergeConfig& config) {
  if (sh_degree < 0 || sh_degree > kMaxShDegree)
    return Error{"merge_gaussians: SH degree " + std::to_string(sh_degree) + " is outside 0..3"};
  const int rest_count = sh_rest_count(sh_degree);
  std::vector<LodMoments> moments;
  std::vector<glm::dvec3> rest;
  moments.reserve(children.size());
  LodMoments m;
  std::vector<glm::dvec3> one(std::size_t(rest_count) + 1);
  for (const Gaussian& g : children) {
    if (leaf_moments(g, sh_degree, config, m, one) != LodLeafStatus::Usable) continue;
    moments.push_back(m);
    rest.insert(rest.end(), one.begin(), one.begin() + rest_count);
  }
  if (moments.empty())
    return Error{"merge_gaussians: none of the " + std::to_string(children.size()) +
                 " children is usable (non-finite, zero weight or too large): no parent"};
  LodMoments out;
  std::vector<glm::dvec3> rest_out(std::size_t(rest_count) + 1);
  combine_moments(moments, rest, rest_count, out, rest_out);
  return moments_to_gaussian(out, rest_out, rest_count, config.spread);
}

}  // namespace gauss
