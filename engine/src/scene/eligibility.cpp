#include "gauss/engine/eligibility.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "cell_grid.h"

namespace gauss {
namespace {

// Closest point on triangle abc to p, by Voronoi region of the vertices, edges and face.
glm::vec3 closest_on_triangle(const glm::vec3& p, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
  const glm::vec3 ab = b - a, ac = c - a, ap = p - a;
  const float d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0.0f && d2 <= 0.0f) return a;
  const glm::vec3 bp = p - b;
  const float d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0.0f && d4 <= d3) return b;
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0f && d1 >= 0.0f && d3 <= 0.0f) return a + ab * (d1 / (d1 - d3));
  const glm::vec3 cp = p - c;
  const float d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0.0f && d5 <= d6) return c;
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0f && d2 >= 0.0f && d6 <= 0.0f) return a + ac * (d2 / (d2 - d6));
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0.0f && (d4 - d3) >= 0.0f && (d5 - d6) >= 0.0f) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const float denom = va + vb + vc;
  if (!(std::abs(denom) > 0.0f)) return a;  // degenerate triangle: its vertices were tested above
  const float v = vb / denom, w = vc / denom;
  return a + ab * v + ac * w;
}

// A triangle touching more grid cells than this is kept in a short list tested by every
// query instead (a few huge triangles must not flood the grid).
constexpr std::int64_t kMaxCellsPerTriangle = 4096;

}  // namespace

struct SurfaceDistanceIndex::Impl {
  float cell{1.0f};
  std::vector<glm::vec3> tri;  // 3 per triangle
  std::vector<std::pair<std::uint64_t, std::uint32_t>> by_cell;  // sorted (cell, triangle)
  scene::CellRanges ranges;
  std::vector<std::uint32_t> big;

  std::int64_t coord(float v) const { return scene::cell_coord(v, cell); }
  bool near(std::uint32_t t, const glm::vec3& p, float d2) const {
    const glm::vec3 q = closest_on_triangle(p, tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]);
    const glm::vec3 e = q - p;
    return glm::dot(e, e) <= d2;
  }
};

SurfaceDistanceIndex::SurfaceDistanceIndex(std::span<const TriangleMesh* const> meshes, float max_query)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.cell = std::max(std::isfinite(max_query) ? max_query : 1.0f, 0.02f);
  for (const TriangleMesh* mesh : meshes) {
    if (!mesh) continue;
    for (std::size_t i = 0; i + 2 < mesh->indices.size(); i += 3) {
      bool valid = true;
      for (int k = 0; k < 3; ++k) valid = valid && mesh->indices[i + k] < mesh->positions.size();
      if (!valid) continue;  // SceneStore validates chunks; a bad index here is skipped, not read
      for (int k = 0; k < 3; ++k) m.tri.push_back(mesh->positions[mesh->indices[i + k]]);
    }
  }
  const auto n = static_cast<std::uint32_t>(m.tri.size() / 3);
  for (std::uint32_t t = 0; t < n; ++t) {
    const glm::vec3 lo = glm::min(m.tri[3 * t], glm::min(m.tri[3 * t + 1], m.tri[3 * t + 2]));
    const glm::vec3 hi = glm::max(m.tri[3 * t], glm::max(m.tri[3 * t + 1], m.tri[3 * t + 2]));
    const std::int64_t x0 = m.coord(lo.x), y0 = m.coord(lo.y), z0 = m.coord(lo.z);
    const std::int64_t x1 = m.coord(hi.x), y1 = m.coord(hi.y), z1 = m.coord(hi.z);
    if ((x1 - x0 + 1) * (y1 - y0 + 1) * (z1 - z0 + 1) > kMaxCellsPerTriangle) {
      m.big.push_back(t);
      continue;
    }
    for (std::int64_t x = x0; x <= x1; ++x)
      for (std::int64_t y = y0; y <= y1; ++y)
        for (std::int64_t z = z0; z <= z1; ++z) m.by_cell.emplace_back(scene::cell_key(x, y, z), t);
  }
  std::sort(m.by_cell.begin(), m.by_cell.end());
  m.ranges = scene::cell_ranges(m.by_cell);
}

SurfaceDistanceIndex::~SurfaceDistanceIndex() = default;
SurfaceDistanceIndex::SurfaceDistanceIndex(SurfaceDistanceIndex&&) noexcept = default;
SurfaceDistanceIndex& SurfaceDistanceIndex::operator=(SurfaceDistanceIndex&&) noexcept = default;

bool SurfaceDistanceIndex::empty() const { return impl_->tri.empty(); }

bool SurfaceDistanceIndex::within(const glm::vec3& p, float d) const {
  const Impl& m = *impl_;
  const float d2 = d * d;
  for (std::uint32_t t : m.big)
    if (m.near(t, p, d2)) return true;
  const std::int64_t x0 = m.coord(p.x - d), y0 = m.coord(p.y - d), z0 = m.coord(p.z - d);
  const std::int64_t x1 = m.coord(p.x + d), y1 = m.coord(p.y + d), z1 = m.coord(p.z + d);
  for (std::int64_t x = x0; x <= x1; ++x)
    for (std::int64_t y = y0; y <= y1; ++y)
      for (std::int64_t z = z0; z <= z1; ++z) {
        auto it = m.ranges.find(scene::cell_key(x, y, z));
        if (it == m.ranges.end()) continue;
        for (std::uint32_t a = it->second.first; a < it->second.second; ++a)
          if (m.near(m.by_cell[a].second, p, d2)) return true;
      }
  return false;
}

Status validate(const EligibilityConfig& c) {
  const auto bad = [](const char* field, float v, const char* want) {
    return Error{std::string("EligibilityConfig: ") + field + " = " + std::to_string(v) + " " + want};
  };
  if (!(c.min_opacity >= 0.0f && c.min_opacity <= 1.0f)) return bad("min_opacity", c.min_opacity, "is outside [0, 1]");
  if (!(c.max_scale > 0.0f)) return bad("max_scale", c.max_scale, "must be positive");
  if (!(c.min_scale >= 0.0f && std::isfinite(c.min_scale))) return bad("min_scale", c.min_scale, "must be finite and >= 0");
  if (!(c.min_scale <= c.max_scale)) return bad("min_scale", c.min_scale, "exceeds max_scale");
  if (!(c.max_surface_distance >= 0.0f && std::isfinite(c.max_surface_distance)))
    return bad("max_surface_distance", c.max_surface_distance, "must be finite and >= 0");
  return Ok{};
}

// Compare in the logit domain: sigmoid(x) < p  <=>  x < logit(p) (monotone).
EligibilityOwnRules::EligibilityOwnRules(const EligibilityConfig& config)
    : min_logit_(config.min_opacity <= 0.0f   ? -INFINITY
                 : config.min_opacity >= 1.0f ? INFINITY
                                              : std::log(double(config.min_opacity) / (1.0 - double(config.min_opacity)))),
      log_max_(std::log(config.max_scale)),
      log_min_(config.min_scale > 0.0f ? std::log(config.min_scale) : -INFINITY),
      min_support_(config.min_support) {}

int EligibilityOwnRules::first_failed(const Gaussian& g) const {
  const float ls = std::max(g.log_scale.x, std::max(g.log_scale.y, g.log_scale.z));
  const bool finite = std::isfinite(g.position.x) && std::isfinite(g.position.y) && std::isfinite(g.position.z) &&
                      std::isfinite(ls) && std::isfinite(g.opacity_logit);
  if (!finite) return 1;
  if (double(g.opacity_logit) < min_logit_) return 2;
  if (ls > log_max_) return 3;
  if (ls < log_min_) return 4;
  if (g.support < min_support_) return 5;
  return 0;
}

bool surface_rule_may_apply(const SceneStore& store, const EligibilityConfig& config) {
  return config.max_surface_distance > 0.0f && !store.surface_chunks().empty();
}

Expected<EligibleSet> filter_eligible(const SceneStore& store, const EligibilityConfig& config) {
  if (auto s = validate(config); !s) return s.error();
  if (store.in_epoch()) return Error{"filter_eligible: the store has an open epoch; filter committed state"};
  EligibleSet out;
  out.epoch = store.epoch();
  out.rule = config;
  EligibilityCounts& n = out.counts;

  std::unique_ptr<SurfaceDistanceIndex> surface;
  if (surface_rule_may_apply(store, config)) {
    std::vector<const TriangleMesh*> meshes;
    for (const SurfaceChunk& c : store.surface_chunks()) meshes.push_back(&c.mesh);
    surface = std::make_unique<SurfaceDistanceIndex>(meshes, config.max_surface_distance);
    if (surface->empty()) surface.reset();
  }
  n.surface_rule_applied = surface != nullptr;
  const EligibilityOwnRules own(config);

  const auto gs = store.gaussians();
  out.indices.reserve(gs.size());
  for (std::size_t i = 0; i < gs.size(); ++i) {
    const Gaussian& g = gs[i];
    if (g.carrier) {
      ++n.carriers;
      continue;
    }
    ++n.considered;
    switch (own.first_failed(g)) {
      case 1: ++n.removed_non_finite; continue;
      case 2: ++n.removed_opacity; continue;
      case 3: ++n.removed_scale_large; continue;
      case 4: ++n.removed_scale_small; continue;
      case 5: ++n.removed_support; continue;
      default: break;
    }
    if (surface && !surface->within(g.position, config.max_surface_distance)) {
      ++n.removed_surface;
    } else {
      out.indices.push_back(static_cast<std::uint32_t>(i));
    }
  }
  n.eligible = out.indices.size();
  return out;
}

Expected<std::shared_ptr<const EligibleSet>> SharedEligibleSet::at(const SceneStore& scene) {
  std::lock_guard lock(mutex_);
  if (set_ && set_->epoch == scene.epoch() && !scene.in_epoch()) return set_;
  auto e = filter_eligible(scene, rule_);
  if (!e) return e.error();
  set_ = std::make_shared<const EligibleSet>(std::move(*e));
  ++filters_;
  return set_;
}

std::uint64_t SharedEligibleSet::filters() const {
  std::lock_guard lock(mutex_);
  return filters_;
}

}  // namespace gauss
