#include "gauss/engine/identity_tracker.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "cell_grid.h"
#include "prng.h"

namespace gauss {
namespace {

constexpr std::uint32_t kNone = 0xFFFFFFFFu;
// Candidates kept per snapshot Gaussian in the similarity pass: bounds memory in dense
// regions; the best few always include the true match when there is one.
constexpr std::size_t kCandidates = 4;

std::string non_finite(const Gaussian& g) {
  if (!finite3(g.position)) return "position";
  if (!finite3(g.log_scale)) return "log_scale";
  if (!std::isfinite(g.opacity_logit)) return "opacity_logit";
  if (!finite3(g.sh_dc)) return "sh_dc";
  for (int k = 0; k < 4; ++k)
    if (!std::isfinite(g.rotation[k])) return "rotation";
  return {};
}

std::uint64_t bits(float f) { return std::bit_cast<std::uint32_t>(f); }

// Hash of exactly the fields the exact pass compares.
std::uint64_t record_hash(const Gaussian& g) {
  std::uint64_t h = g.carrier ? 0xCA77'1E70ull : 0x5EED'0000ull;
  const auto add = [&](float f) { h = scene::hash(h, bits(f)); };
  for (int k = 0; k < 3; ++k) {
    add(g.position[k]);
    add(g.log_scale[k]);
    add(g.sh_dc[k]);
  }
  for (int k = 0; k < 4; ++k) add(g.rotation[k]);
  add(g.opacity_logit);
  return h;
}

bool same_record(const Gaussian& a, const Gaussian& b) {
  return a.carrier == b.carrier && a.position == b.position && a.log_scale == b.log_scale && a.sh_dc == b.sh_dc &&
         a.rotation == b.rotation && a.opacity_logit == b.opacity_logit;
}

float max_abs3(const glm::vec3& v) { return std::max(std::abs(v.x), std::max(std::abs(v.y), std::abs(v.z))); }

struct Pair {
  float cost;
  std::uint32_t cur;
  std::uint32_t prev;
};

}  // namespace

Expected<IdentityReport> track_identity(std::span<const Gaussian> previous, std::span<Gaussian> current,
                                        const IdentityTrackerConfig& config,
                                        const std::function<GaussianId()>& allocate) {
  const auto positive = [](float v) { return std::isfinite(v) && v > 0.0f; };
  if (!positive(config.max_distance_sigmas) || !positive(config.max_log_scale_change) ||
      !positive(config.max_sh_dc_change) || !positive(config.max_opacity_logit_change) ||
      !(std::isfinite(config.cell_size) && config.cell_size >= 0.0f))
    return Error{"track_identity: tolerances must be positive and finite, cell_size finite and >= 0"};
  if (previous.size() >= kNone || current.size() >= kNone)
    return Error{"track_identity: more than 4294967294 Gaussians"};
  for (std::size_t i = 0; i < current.size(); ++i)
    if (auto f = non_finite(current[i]); !f.empty())
      return Error{"track_identity: snapshot Gaussian " + std::to_string(i) + " has a non-finite " + f};
  for (std::size_t i = 0; i < previous.size(); ++i)
    if (auto f = non_finite(previous[i]); !f.empty())
      return Error{"track_identity: previous Gaussian " + std::to_string(i) + " has a non-finite " + f};

  IdentityReport report;
  report.previous = previous.size();
  report.current = current.size();
  std::vector<std::uint32_t> match(current.size(), kNone);  // current -> previous index
  std::vector<std::uint8_t> taken(previous.size(), 0);

  // 1. Exact pass: previous records sorted by hash (a flat array: no per-node allocation),
  //    equal hashes in index order; each snapshot record takes the first unused equal one.
  {
    std::vector<std::pair<std::uint64_t, std::uint32_t>> by_hash(previous.size());
    for (std::size_t j = 0; j < previous.size(); ++j) by_hash[j] = {record_hash(previous[j]), static_cast<std::uint32_t>(j)};
    std::sort(by_hash.begin(), by_hash.end());
    for (std::size_t i = 0; i < current.size(); ++i) {
      const std::uint64_t h = record_hash(current[i]);
      auto it = std::lower_bound(by_hash.begin(), by_hash.end(), std::make_pair(h, std::uint32_t{0}));
      for (; it != by_hash.end() && it->first == h; ++it) {
        const std::uint32_t j = it->second;
        if (!taken[j] && same_record(previous[j], current[i])) {
          taken[j] = 1;
          match[i] = j;
          ++report.exact;
          break;
        }
      }
    }
  }

  // 2. Similarity pass over what is left on both sides.
  std::vector<std::uint32_t> prev_left;
  for (std::size_t j = 0; j < previous.size(); ++j)
    if (!taken[j]) prev_left.push_back(static_cast<std::uint32_t>(j));
  std::vector<std::uint32_t> cur_left;
  for (std::size_t i = 0; i < current.size(); ++i)
    if (match[i] == kNone) cur_left.push_back(static_cast<std::uint32_t>(i));

  if (!prev_left.empty() && !cur_left.empty()) {
    std::vector<float> sigma(prev_left.size());
    for (std::size_t k = 0; k < prev_left.size(); ++k) {
      const glm::vec3& ls = previous[prev_left[k]].log_scale;
      sigma[k] = std::exp(std::max(ls.x, std::max(ls.y, ls.z)));
    }
    float cell = config.cell_size;
    if (cell <= 0.0f) {
      std::vector<float> s = sigma;
      auto p90 = s.begin() + static_cast<std::ptrdiff_t>(s.size() * 9 / 10);
      std::nth_element(s.begin(), p90, s.end());
      cell = 2.0f * config.max_distance_sigmas * *p90;
    }
    cell = std::max(cell, 1e-6f);
    report.cell_size = cell;

    // Previous Gaussians copied compactly in cell order (neighbours in space are neighbours
    // in memory), with each cell's range in a hash map.
    struct Compact {
      glm::vec3 position;
      float radius;
      glm::vec3 log_scale;
      float opacity_logit;
      glm::vec3 sh_dc;
      std::uint32_t prev;
      bool carrier;
    };
    const auto key_of = [&](const glm::vec3& p) {
      return scene::cell_key(scene::cell_coord(p.x, cell), scene::cell_coord(p.y, cell), scene::cell_coord(p.z, cell));
    };
    std::vector<std::pair<std::uint64_t, std::uint32_t>> by_cell(prev_left.size());
    for (std::size_t k = 0; k < prev_left.size(); ++k)
      by_cell[k] = {key_of(previous[prev_left[k]].position), static_cast<std::uint32_t>(k)};
    std::sort(by_cell.begin(), by_cell.end());
    std::vector<Compact> compact(by_cell.size());
    for (std::size_t a = 0; a < by_cell.size(); ++a) {
      const std::uint32_t k = by_cell[a].second;
      const Gaussian& q = previous[prev_left[k]];
      compact[a] = {q.position, std::min(config.max_distance_sigmas * sigma[k], 0.5f * cell), q.log_scale,
                    q.opacity_logit, q.sh_dc, prev_left[k], q.carrier};
    }
    const scene::CellRanges ranges = scene::cell_ranges(by_cell);
    // Queries in cell order too, for the same locality (the result does not depend on it:
    // pairs are sorted by cost and index before the greedy assignment).
    std::vector<std::pair<std::uint64_t, std::uint32_t>> queries(cur_left.size());
    for (std::size_t k = 0; k < cur_left.size(); ++k) queries[k] = {key_of(current[cur_left[k]].position), cur_left[k]};
    std::sort(queries.begin(), queries.end());

    std::vector<Pair> pairs;
    pairs.reserve(cur_left.size() * 2);
    for (const auto& query : queries) {
      const std::uint32_t i = query.second;
      const Gaussian& g = current[i];
      // Every candidate lies within half a cell per axis: the 2x2x2 cells from p - cell/2.
      const std::int64_t bx = scene::cell_coord(g.position.x - 0.5f * cell, cell);
      const std::int64_t by = scene::cell_coord(g.position.y - 0.5f * cell, cell);
      const std::int64_t bz = scene::cell_coord(g.position.z - 0.5f * cell, cell);
      std::array<Pair, kCandidates> best;
      std::size_t n_best = 0;
      for (int dx = 0; dx < 2; ++dx)
        for (int dy = 0; dy < 2; ++dy)
          for (int dz = 0; dz < 2; ++dz) {
            auto r = ranges.find(scene::cell_key(bx + dx, by + dy, bz + dz));
            if (r == ranges.end()) continue;
            for (std::uint32_t a = r->second.first; a < r->second.second; ++a) {
              const Compact& q = compact[a];
              if (q.carrier != g.carrier) continue;
              const glm::vec3 d = g.position - q.position;
              const float dist2 = d.x * d.x + d.y * d.y + d.z * d.z;
              if (dist2 > q.radius * q.radius) continue;
              const float ds = max_abs3(g.log_scale - q.log_scale) / config.max_log_scale_change;
              const float dc = max_abs3(g.sh_dc - q.sh_dc) / config.max_sh_dc_change;
              const float dop = std::abs(g.opacity_logit - q.opacity_logit) / config.max_opacity_logit_change;
              if (ds > 1.0f || dc > 1.0f || dop > 1.0f) continue;
              const Pair p{dist2 / (q.radius * q.radius) + ds * ds + dc * dc + dop * dop, i, q.prev};
              // Keep the kCandidates cheapest (ties by previous index).
              const auto worse = [](const Pair& x, const Pair& y) {
                return x.cost != y.cost ? x.cost > y.cost : x.prev > y.prev;
              };
              if (n_best < kCandidates) {
                best[n_best++] = p;
              } else {
                auto w = std::max_element(best.begin(), best.end(),
                                          [&](const Pair& x, const Pair& y) { return worse(y, x); });
                if (worse(*w, p)) *w = p;
              }
            }
          }
      pairs.insert(pairs.end(), best.begin(), best.begin() + static_cast<std::ptrdiff_t>(n_best));
    }
    std::sort(pairs.begin(), pairs.end(), [](const Pair& x, const Pair& y) {
      if (x.cost != y.cost) return x.cost < y.cost;
      if (x.cur != y.cur) return x.cur < y.cur;
      return x.prev < y.prev;
    });
    for (const Pair& p : pairs)
      if (match[p.cur] == kNone && !taken[p.prev]) {
        match[p.cur] = p.prev;
        taken[p.prev] = 1;
      }
  }

  // 3. Ids: previous ids for matches, fresh ones (in snapshot order) for the rest.
  for (std::size_t i = 0; i < current.size(); ++i) {
    if (match[i] != kNone) {
      current[i].id = previous[match[i]].id;
      ++report.kept;
    } else {
      current[i].id = allocate();
      ++report.fresh;
    }
  }
  report.removed = report.previous - report.kept;
  return report;
}

}  // namespace gauss
