// Robust bounds and the default framing of a splat scene (contract in scene_framing.h).
#include "gauss/engine/scene_framing.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>

namespace gauss {
namespace {

double opacity_weight(float logit) {
  if (std::isnan(logit)) return 0.0;
  return 1.0 / (1.0 + std::exp(-static_cast<double>(logit)));  // +inf -> 1, -inf -> 0
}

// The unweighted percentile box, by order statistics (the evaluation's region: the same
// indices as before opacity weighting existed, so its reports do not move).
void count_bounds(const std::vector<glm::vec3>& ps, RobustBounds& out) {
  std::vector<float> axis(ps.size());
  const std::size_t i_lo = ps.size() * 2 / 100, i_hi = ps.size() - 1 - i_lo;
  for (int a = 0; a < 3; ++a) {
    for (std::size_t i = 0; i < ps.size(); ++i) axis[i] = ps[i][a];
    std::nth_element(axis.begin(), axis.begin() + static_cast<std::ptrdiff_t>(i_lo), axis.end());
    out.lo[a] = axis[i_lo];
    std::nth_element(axis.begin(), axis.begin() + static_cast<std::ptrdiff_t>(i_hi), axis.end());
    out.hi[a] = axis[i_hi];
  }
}

using WeightedValue = std::pair<float, double>;  // a centre's coordinate on one axis, its weight

// Walking `axis` in the order `before` from its front, the first place at which the running
// sum of weights exceeds `cut`, looking at most `steps` places (else `steps`). Only that
// front needs its order: the quantiles sought lie in 2 % tails, so the `m` first by `before`
// are brought forward (nth_element) and sorted, m growing while they hold too little weight;
// sorting every axis whole was most of a 1M scene's framing. Ties fall in some order, as
// they did under std::sort.
template <class Before>
std::size_t weighted_walk(std::vector<WeightedValue>& axis, double cut, std::size_t steps, Before before) {
  std::size_t m = std::min(steps + 1, static_cast<std::size_t>(0.04 * static_cast<double>(axis.size())) + 256);
  for (;;) {
    std::nth_element(axis.begin(), axis.begin() + static_cast<std::ptrdiff_t>(m - 1), axis.end(), before);
    std::sort(axis.begin(), axis.begin() + static_cast<std::ptrdiff_t>(m), before);
    double cum = 0.0;
    for (std::size_t k = 0; k < std::min(m, steps); ++k) {
      cum += axis[k].second;
      if (cum > cut) return k;
    }
    if (m > steps) return steps;
    m = std::min(steps + 1, 2 * m);
  }
}

// Weighted quantiles per axis: symmetric from both ends, so a single heavy centre is both
// bounds and equal weights give the same box as the count for large n.
void weighted_bounds(const std::vector<glm::vec3>& ps, const std::vector<double>& w, double total, RobustBounds& out) {
  std::vector<WeightedValue> axis(ps.size());
  const double cut_lo = kRobustLowQuantile * total, cut_hi = (1.0 - kRobustHighQuantile) * total;
  const std::size_t n = ps.size();
  for (int a = 0; a < 3; ++a) {
    for (std::size_t i = 0; i < n; ++i) axis[i] = {ps[i][a], w[i]};
    // From the low end: the first centre past cut_lo of the weight (at most the last).
    const std::size_t lo = weighted_walk(axis, cut_lo, n - 1, [](const auto& x, const auto& y) { return x.first < y.first; });
    out.lo[a] = axis[lo].first;
    // From the high end, never past the low bound's place (n - 1 - lo steps from the top).
    const std::size_t hi =
        weighted_walk(axis, cut_hi, n - 1 - lo, [](const auto& x, const auto& y) { return y.first < x.first; });
    out.hi[a] = axis[hi].first;
  }
}

}  // namespace

glm::dvec3 view_side(const glm::dvec3& centre, const glm::dvec3& half, const glm::dvec3& up,
                     const std::optional<glm::dvec3>& seen_from) {
  const auto horizontal = [&](const glm::dvec3& v) { return v - glm::dot(v, up) * up; };
  const double footprint = glm::length(horizontal(glm::abs(half)));
  // The unit horizontal direction toward `from`, when `from` stands outside the footprint.
  const auto toward = [&](const glm::dvec3& from) -> std::optional<glm::dvec3> {
    const glm::dvec3 side = horizontal(from - centre);
    const double d = glm::length(side);
    if (std::isfinite(d) && d > footprint && d > 0.0) return side / d;
    return std::nullopt;
  };
  if (seen_from)
    if (auto side = toward(*seen_from)) return *side;
  if (auto side = toward(glm::dvec3(0.0))) return *side;
  return -front_direction(up);
}

RobustBounds robust_bounds(std::span<const Gaussian> gaussians, BoundsWeighting weighting) {
  RobustBounds out;
  std::vector<glm::vec3> ps;
  std::vector<double> w;
  ps.reserve(gaussians.size());
  if (weighting == BoundsWeighting::Opacity) w.reserve(gaussians.size());
  double total = 0.0;
  for (const Gaussian& g : gaussians) {
    if (!finite3(g.position)) continue;
    ps.push_back(g.position);
    if (weighting == BoundsWeighting::Opacity) {
      w.push_back(opacity_weight(g.opacity_logit));
      total += w.back();
    }
  }
  out.finite = ps.size();
  if (ps.empty()) return out;  // the unit box: nothing to frame
  // A total that underflowed to 0 (every opacity ~0) says nothing about where the subject
  // is: count the centres instead.
  if (weighting == BoundsWeighting::Opacity && total > 0.0 && std::isfinite(total)) {
    weighted_bounds(ps, w, total, out);
    out.opacity_weighted = true;
  } else {
    count_bounds(ps, out);
  }
  return out;
}

glm::dvec3 front_direction(const glm::dvec3& up) {
  const glm::dvec3 a = glm::abs(up);
  const glm::dvec3 r0 = a.x > a.y && a.x > a.z ? glm::dvec3(0.0, 1.0, 0.0) : glm::dvec3(1.0, 0.0, 0.0);
  const glm::dvec3 right = glm::normalize(r0 - glm::dot(r0, up) * up);
  return -glm::cross(right, up);
}

Framing frame_bounds(const glm::dvec3& lo, const glm::dvec3& hi, const glm::dvec3& up, const FramingLens& lens,
                     const std::optional<glm::dvec3>& seen_from) {
  return frame_preset(lo, hi, up, lens, ViewPreset::Front, seen_from);
}

Framing frame_preset(const glm::dvec3& lo_in, const glm::dvec3& hi_in, const glm::dvec3& up_in, const FramingLens& lens,
                     ViewPreset preset, const std::optional<glm::dvec3>& seen_from) {
  Framing fr;
  const double up_len = glm::length(up_in);
  fr.up = std::isfinite(up_len) && up_len > 1e-12 ? up_in / up_len : glm::dvec3(0.0, 1.0, 0.0);
  glm::dvec3 lo = glm::min(lo_in, hi_in), hi = glm::max(lo_in, hi_in);
  if (!finite3(lo) || !finite3(hi)) lo = glm::dvec3(-1.0), hi = glm::dvec3(1.0);
  const glm::dvec3 centre = 0.5 * (lo + hi);
  glm::dvec3 half = 0.5 * (hi - lo);
  const double largest = std::max({half.x, half.y, half.z});
  // Relative to the coordinates' magnitude: float centres far from the origin are never
  // closer than their own rounding.
  if (!(largest > 1e-6 * std::max(1.0, glm::length(centre)))) half = glm::dvec3(kPointBoxHalfExtent);
  fr.lo = centre - half;
  fr.hi = centre + half;
  fr.target = centre;

  // The view direction: from the side the camera stands on, tilted down by the elevation
  // (clamped short of vertical, where image-up is undefined). The side view stands at the
  // front view's right: right = f x up for a horizontal f = -side, so up x side.
  const glm::dvec3 front_side = view_side(centre, half, fr.up, seen_from);
  const glm::dvec3 side = preset == ViewPreset::Side ? glm::cross(fr.up, front_side) : front_side;
  const double e = std::clamp(preset == ViewPreset::Top ? kTopElevation : lens.elevation, -kTopElevation, kTopElevation);
  const glm::dvec3 f = glm::normalize(-std::cos(e) * side - std::sin(e) * fr.up);
  const glm::dvec3 right = glm::normalize(glm::cross(f, fr.up));
  const glm::dvec3 down = glm::cross(f, right);
  // Tangents of the half-angles the box may fill (principal point at the centre).
  const double fill = std::clamp(lens.fill, 0.05, 1.0);
  const double tx = fill * 0.5 * std::max(1u, lens.width) / std::max(lens.fx, 1e-9);
  const double ty = fill * 0.5 * std::max(1u, lens.height) / std::max(lens.fy, 1e-9);
  // For a corner at offset o from the centre and the eye at centre - D f: depth D + o.f,
  // image x (o.right) / depth. |o.right| <= tx (D + o.f) <=> D >= |o.right| / tx - o.f.
  double d = 0.0;
  for (int i = 0; i < 8; ++i) {
    const glm::dvec3 o((i & 1) ? half.x : -half.x, (i & 2) ? half.y : -half.y, (i & 4) ? half.z : -half.z);
    const double z = glm::dot(o, f);
    d = std::max({d, std::abs(glm::dot(o, right)) / tx - z, std::abs(glm::dot(o, down)) / ty - z,
                  std::max(lens.min_depth, 0.0) - z});
  }
  // Every corner in front of the camera puts the eye outside the (convex) box; a hair more
  // so that rounding does not put the nearest corner exactly on the near plane.
  fr.distance = d * (1.0 + 1e-6) + 1e-9;
  fr.eye = centre - fr.distance * f;
  return fr;
}

Camera framed_camera(const Framing& fr, const FramingLens& lens) {
  Camera c;
  c.width = std::max(1u, lens.width);
  c.height = std::max(1u, lens.height);
  c.fx = lens.fx;
  c.fy = lens.fy;
  c.cx = 0.5 * c.width;
  c.cy = 0.5 * c.height;
  c.world_to_camera = glm::inverse(opencv_look_at(fr.eye, fr.target, fr.up));
  const double reach = fr.distance + glm::length(fr.hi - fr.lo);
  c.far_plane = std::max(c.far_plane, 2.0 * reach);
  return c;
}

}  // namespace gauss
