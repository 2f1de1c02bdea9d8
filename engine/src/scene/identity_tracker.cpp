#include "gauss/engine/identity_tracker.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "gauss/engine/id_index.h"
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

// Bit k set when entry k of the Chunk from xs, ys, zs lies within sqrt(r2s[k]) of p, its
// squared distance in dist2[k]. Four at a time where SSE2 is (x86-64 always): the same float
// operations in the same order as one at a time (no contraction in ISO C++ mode), so the same
// bits; GCC at -O2 left the plain loop scalar, and this scan was most of the similarity pass.
template <std::size_t Chunk>
unsigned near_mask(const glm::vec3& p, const float* xs, const float* ys, const float* zs, const float* r2s,
                   float* dist2) {
  static_assert(Chunk % 4 == 0 && Chunk <= 32);
  unsigned near = 0;
#if defined(__SSE2__)
  const __m128 px = _mm_set1_ps(p.x), py = _mm_set1_ps(p.y), pz = _mm_set1_ps(p.z);
  for (std::size_t k = 0; k < Chunk; k += 4) {
    const __m128 ex = _mm_sub_ps(px, _mm_loadu_ps(xs + k));
    const __m128 ey = _mm_sub_ps(py, _mm_loadu_ps(ys + k));
    const __m128 ez = _mm_sub_ps(pz, _mm_loadu_ps(zs + k));
    const __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(ex, ex), _mm_mul_ps(ey, ey)), _mm_mul_ps(ez, ez));
    _mm_storeu_ps(dist2 + k, d2);
    near |= unsigned(_mm_movemask_ps(_mm_cmple_ps(d2, _mm_loadu_ps(r2s + k)))) << k;
  }
#else
  for (std::size_t k = 0; k < Chunk; ++k) {
    const float ex = p.x - xs[k], ey = p.y - ys[k], ez = p.z - zs[k];
    dist2[k] = ex * ex + ey * ey + ez * ez;
    near |= unsigned(dist2[k] <= r2s[k]) << k;
  }
#endif
  return near;
}

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

  // 1. Exact pass: each snapshot record takes the lowest-indexed unused previous record that
  //    is bit-identical to it. Previous records are chained by hash (head: the lowest index
  //    with the hash, next_same: the next higher one), found by one index lookup each: a sort
  //    and a binary search per record were half a second at a million, most of it misses.
  {
    detail::IdIndex head;  // record hash -> lowest previous index with it
    head.reserve(previous.size());
    std::uint32_t head_of_empty = kNone;  // the hash 2^64 - 1, which IdIndex cannot hold
    std::vector<std::uint32_t> next_same(previous.size(), kNone);
    for (std::size_t j = previous.size(); j-- > 0;) {
      const std::uint64_t h = record_hash(previous[j]);
      std::uint32_t* first = h == detail::IdIndex::kEmpty ? &head_of_empty : head.find(h);
      if (first) {
        next_same[j] = *first;
        *first = static_cast<std::uint32_t>(j);
      } else {
        head.set(h, static_cast<std::uint32_t>(j));
      }
    }
    std::vector<std::uint64_t> hashes(current.size());
    for (std::size_t i = 0; i < current.size(); ++i) hashes[i] = record_hash(current[i]);
    constexpr std::size_t kAhead = 16;  // lookups asked of the cache this far ahead
    for (std::size_t i = 0; i < current.size(); ++i) {
      if (i + kAhead < current.size()) head.prefetch(hashes[i + kAhead]);
      const std::uint64_t h = hashes[i];
      const std::uint32_t* first = h == detail::IdIndex::kEmpty ? &head_of_empty : head.find(h);
      for (std::uint32_t j = first ? *first : kNone; j != kNone; j = next_same[j])
        if (!taken[j] && same_record(previous[j], current[i])) {
          taken[j] = 1;
          match[i] = j;
          ++report.exact;
          break;
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

    // Previous Gaussians in cell order (neighbours in space are neighbours in memory), each
    // cell's range found through an index. What the distance test reads lies in arrays of its
    // own (x, y, z, radius^2), which a query scans kChunk at a time, four at once (near_mask):
    // a cell of the automatic size holds about a hundred Gaussians at a million,
    // and a query reads eight cells, of which few lie within reach (most of the similarity
    // pass's time went to that scan). Only those are read further.
    const auto key_of = [&](const glm::vec3& p) {
      return scene::cell_key(scene::cell_coord(p.x, cell), scene::cell_coord(p.y, cell), scene::cell_coord(p.z, cell));
    };
    std::vector<std::pair<std::uint64_t, std::uint32_t>> by_cell(prev_left.size());
    for (std::size_t k = 0; k < prev_left.size(); ++k)
      by_cell[k] = {key_of(previous[prev_left[k]].position), static_cast<std::uint32_t>(k)};
    std::sort(by_cell.begin(), by_cell.end());
    struct Candidate {
      glm::vec3 log_scale;
      float opacity_logit;
      glm::vec3 sh_dc;
      std::uint32_t prev;
      bool carrier;
    };
    constexpr std::size_t kChunk = 8;
    const std::size_t count = by_cell.size();
    // kChunk entries of padding that no query reaches (radius^2 -1), so a scan reads whole chunks.
    std::vector<float> xs(count + kChunk, 0.0f), ys(count + kChunk, 0.0f), zs(count + kChunk, 0.0f),
        r2s(count + kChunk, -1.0f);
    std::vector<Candidate> candidates(count);
    constexpr std::size_t kAhead = 16;  // reads in cell order are scattered: asked for early
    for (std::size_t a = 0; a < count; ++a) {
      if (a + kAhead < count) __builtin_prefetch(&previous[prev_left[by_cell[a + kAhead].second]]);
      const std::uint32_t k = by_cell[a].second;
      const Gaussian& q = previous[prev_left[k]];
      const float radius = std::min(config.max_distance_sigmas * sigma[k], 0.5f * cell);
      xs[a] = q.position.x;
      ys[a] = q.position.y;
      zs[a] = q.position.z;
      r2s[a] = radius * radius;
      candidates[a] = {q.log_scale, q.opacity_logit, q.sh_dc, prev_left[k], q.carrier};
    }
    detail::IdIndex cell_at;  // cell key (< 2^63) -> its place in cell_range
    std::vector<std::pair<std::uint32_t, std::uint32_t>> cell_range;
    for (std::size_t a = 0; a < count;) {
      std::size_t b = a;
      while (b < count && by_cell[b].first == by_cell[a].first) ++b;
      cell_at.set(by_cell[a].first, static_cast<std::uint32_t>(cell_range.size()));
      cell_range.emplace_back(static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b));
      a = b;
    }
    // Queries in cell order too, for the same locality (the result does not depend on it:
    // pairs are sorted by cost and index before the greedy assignment), and what they read
    // copied out in that order: read in place, each query began with misses on its
    // Gaussian's lines (a quarter of the pass at a million).
    struct Query {
      glm::vec3 position;
      float opacity_logit;
      glm::vec3 log_scale;
      std::uint32_t cur;
      glm::vec3 sh_dc;
      bool carrier;
    };
    std::vector<Query> queries(cur_left.size());
    {
      std::vector<std::pair<std::uint64_t, std::uint32_t>> order(cur_left.size());
      for (std::size_t k = 0; k < cur_left.size(); ++k) order[k] = {key_of(current[cur_left[k]].position), cur_left[k]};
      std::sort(order.begin(), order.end());
      for (std::size_t a = 0; a < order.size(); ++a) {
        if (a + kAhead < order.size()) __builtin_prefetch(&current[order[a + kAhead].second]);
        const Gaussian& g = current[order[a].second];
        queries[a] = {g.position, g.opacity_logit, g.log_scale, order[a].second, g.sh_dc, g.carrier};
      }
    }

    std::vector<Pair> pairs;
    pairs.reserve(cur_left.size() * 2);
    for (const Query& g : queries) {
      const std::uint32_t i = g.cur;
      // Every candidate lies within half a cell per axis: the 2x2x2 cells from p - cell/2.
      const std::int64_t bx = scene::cell_coord(g.position.x - 0.5f * cell, cell);
      const std::int64_t by = scene::cell_coord(g.position.y - 0.5f * cell, cell);
      const std::int64_t bz = scene::cell_coord(g.position.z - 0.5f * cell, cell);
      std::array<Pair, kCandidates> best;
      std::size_t n_best = 0;
      const auto consider = [&](std::size_t a, float dist2) {
        const Candidate& q = candidates[a];
        if (q.carrier != g.carrier) return;
        const float ds = max_abs3(g.log_scale - q.log_scale) / config.max_log_scale_change;
        const float dc = max_abs3(g.sh_dc - q.sh_dc) / config.max_sh_dc_change;
        const float dop = std::abs(g.opacity_logit - q.opacity_logit) / config.max_opacity_logit_change;
        if (ds > 1.0f || dc > 1.0f || dop > 1.0f) return;
        const Pair p{dist2 / r2s[a] + ds * ds + dc * dc + dop * dop, i, q.prev};
        // Keep the kCandidates cheapest (ties by previous index).
        const auto worse = [](const Pair& x, const Pair& y) { return x.cost != y.cost ? x.cost > y.cost : x.prev > y.prev; };
        if (n_best < kCandidates) {
          best[n_best++] = p;
        } else {
          auto w = std::max_element(best.begin(), best.end(), [&](const Pair& x, const Pair& y) { return worse(y, x); });
          if (worse(*w, p)) *w = p;
        }
      };
      for (int dx = 0; dx < 2; ++dx)
        for (int dy = 0; dy < 2; ++dy)
          for (int dz = 0; dz < 2; ++dz) {
            const std::uint32_t* r = cell_at.find(scene::cell_key(bx + dx, by + dy, bz + dz));
            if (!r) continue;
            const auto [begin, end] = cell_range[*r];
            for (std::size_t a = begin; a < end; a += kChunk) {
              // The same float operations as one at a time (no contraction: ISO C++ mode),
              // so the same bits.
              // Few are near: their bits are visited, not every entry's branch.
              float dist2[kChunk];
              unsigned near = near_mask<kChunk>(g.position, xs.data() + a, ys.data() + a, zs.data() + a,
                                                r2s.data() + a, dist2);
              if (end - a < kChunk) near &= (1u << (end - a)) - 1u;
              for (; near != 0; near &= near - 1) {
                const auto k = static_cast<std::size_t>(std::countr_zero(near));
                consider(a + k, dist2[k]);
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
    if (i + 16 < current.size() && match[i + 16] != kNone) __builtin_prefetch(&previous[match[i + 16]].id);
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
