// LodCutter: greedy view-dependent refinement of a LodHierarchy under a node budget, in the
// order of effective priority, without a heap over the whole frontier (lod_cut.h).
#include "gauss/engine/lod_cut.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>

#include "id_sort.h"
#include "select/view_score.h"

namespace gauss {

namespace {

constexpr std::uint32_t kNone = 0xFFFFFFFFu;
// Per layout node: how a query's exclusion touches it.
constexpr std::uint8_t kExcludedAll = 1;    // every leaf under it is excluded: not in the cut
constexpr std::uint8_t kExcludedMixed = 2;  // it mixes excluded and other leaves: always refined

// Buckets of the refinement histogram: the top 16 bits of a non-negative float (sign,
// exponent, 7 mantissa bits), so a bucket spans under 1 % of its values; +inf (the forced
// nodes) is the last.
constexpr std::uint32_t kBucketShift = 16;
constexpr std::uint32_t kBuckets = (0x7F800000u >> kBucketShift) + 1;

std::uint32_t bucket_of(float p) { return std::bit_cast<std::uint32_t>(p) >> kBucketShift; }

// One sphere's view error (the selector's view terms, select/view_score.h).
float sphere_error(const select_detail::ViewParams& vp, const glm::vec3& centre, float radius) {
  const std::uint8_t not_resident = 0;
  std::uint32_t key = 0;
  select_detail::score_view_spheres(1, &centre.x, &centre.y, &centre.z, &radius, &not_resident, vp, &key);
  const float e = std::bit_cast<float>(key);
  return e >= 0.0f && e <= std::numeric_limits<float>::max() ? e : 0.0f;
}

}  // namespace

// The hierarchy's interior nodes in breadth-first order from the root (index k), structure
// of arrays: a node's interior children are consecutive (k range), and its leaf children are
// one run of the leaf arrays. Built once per hierarchy generation; a cut then reads the tree
// sequentially instead of chasing pool indices.
struct LodCutter::Layout {
  // On huge pages (detail::TableVector): a cut reads the rank tables at random, a few entries
  // per page, and at a million leaves they span 20 MB. (The build's short-lived scratch stays
  // on plain vectors: a host builds a layout every epoch, and the heap keeps their memory from
  // one build to the next, where huge-page blocks came back fresh each time; a first cut with
  // its layout took 110-142 against 90-139 ms at a million leaves.)
  template <class T>
  using Table = detail::TableVector<T>;
  const LodHierarchy* hierarchy{nullptr};
  std::uint64_t generation{0};
  std::uint32_t root_leaf{kNone};  // the pool index of the root when it is a leaf
  Table<float> cx, cy, cz, radius;
  Table<std::uint32_t> parent;  // k of the parent; kNone for the root (k = 0)
  Table<std::uint16_t> depth;
  Table<std::uint32_t> delta;  // nodes its refinement adds to a cut: children - 1
  Table<std::uint32_t> kid_begin, kid_count;    // interior children
  Table<std::uint32_t> leaf_begin, leaf_count;  // leaf children
  Table<std::uint32_t> pool;                    // pool index
  Table<std::uint64_t> id;
  Table<std::uint32_t> slot;  // record slot
  Table<std::uint32_t> k_rank;  // k's place among the interior nodes in id order
  // Leaf children in breadth-first order of their parents: each one's place in id order.
  Table<std::uint32_t> leaf_rank;
  // By rank (ascending id): what a cut emits, read in order so its output comes sorted; one
  // entry per node, so emitting one costs one cache line.
  struct Emitted {
    std::uint64_t id;
    std::uint32_t pool;
    std::uint32_t place;  // a leaf's leaf_source, an interior node's record slot
  };
  Table<Emitted> rank_leaf, rank_interior;
  Table<std::uint32_t> k_of_pool;  // pool index -> k; kNone for leaves and free entries
  std::vector<lod_detail::IdPair> sort_pairs, sort_scratch;

  std::size_t size() const { return pool.size(); }

  void build(const LodHierarchy& h) {
    hierarchy = &h;
    generation = h.generation();
    root_leaf = kNone;
    for (auto* v : {&cx, &cy, &cz, &radius}) v->clear();
    for (auto* v : {&parent, &delta, &kid_begin, &kid_count, &leaf_begin, &leaf_count, &pool, &slot, &k_rank, &leaf_rank})
      v->clear();
    rank_leaf.clear();
    rank_interior.clear();
    depth.clear();
    id.clear();
    k_of_pool.assign(h.nodes().size(), kNone);
    if (h.root() == kNoLodNode) return;
    if (h.node(h.root()).leaf) {
      root_leaf = h.root();
      return;
    }
    const std::size_t interior = h.interior_count();
    for (auto* v : {&cx, &cy, &cz, &radius}) v->reserve(interior);
    for (auto* v : {&parent, &kid_begin, &kid_count, &leaf_begin, &leaf_count, &pool, &slot}) v->reserve(interior);
    depth.reserve(interior);
    id.reserve(interior);
    std::vector<std::uint32_t> leaf_pool, leaf_place;  // breadth-first order, until ranked
    std::vector<std::uint64_t> leaf_id;
    leaf_pool.reserve(h.leaf_count());
    leaf_place.reserve(h.leaf_count());
    leaf_id.reserve(h.leaf_count());
    auto push = [&](std::uint32_t n, std::uint32_t up, std::uint16_t d) {
      const LodNode& node = h.node(n);
      k_of_pool[n] = static_cast<std::uint32_t>(pool.size());
      pool.push_back(n);
      // A record is finite by construction (lod_hierarchy.h); should a sphere not be, it
      // scores 0 (a point at the origin) rather than poisoning the priorities below it.
      const bool finite = std::isfinite(node.centre.x) && std::isfinite(node.centre.y) &&
                          std::isfinite(node.centre.z) && std::isfinite(node.radius) && node.radius < 1e30f;
      cx.push_back(finite ? node.centre.x : 0.0f);
      cy.push_back(finite ? node.centre.y : 0.0f);
      cz.push_back(finite ? node.centre.z : 0.0f);
      radius.push_back(finite ? node.radius : 0.0f);
      parent.push_back(up);
      depth.push_back(d);
      id.push_back(to_underlying(node.id));
      slot.push_back(h.record_slot(node));
    };
    push(h.root(), kNone, 0);
    kid_begin.resize(1);
    kid_count.resize(1);
    delta.resize(1);
    leaf_begin.resize(1);
    leaf_count.resize(1);
    for (std::uint32_t k = 0; k < pool.size(); ++k) {
      const LodNode& node = h.node(pool[k]);
      kid_begin[k] = static_cast<std::uint32_t>(pool.size());
      leaf_begin[k] = static_cast<std::uint32_t>(leaf_pool.size());
      for (std::uint32_t c : h.children(node)) {
        const LodNode& child = h.node(c);
        if (child.leaf) {
          leaf_pool.push_back(c);
          leaf_id.push_back(to_underlying(child.id));
          leaf_place.push_back(h.leaf_source(child));
        } else {
          push(c, k, static_cast<std::uint16_t>(std::min<int>(depth[k] + 1, 0xFFFF)));
        }
      }
      kid_count[k] = static_cast<std::uint32_t>(pool.size()) - kid_begin[k];
      leaf_count[k] = static_cast<std::uint32_t>(leaf_pool.size()) - leaf_begin[k];
      delta[k] = std::max<std::uint32_t>(kid_count[k] + leaf_count[k], 1) - 1;
      kid_begin.resize(pool.size());
      kid_count.resize(pool.size());
      delta.resize(pool.size());
      leaf_begin.resize(pool.size());
      leaf_count.resize(pool.size());
    }
    // Ranks by id: a cut marks what it emits by rank and reads it out in id order.
    auto rank = [&](const auto& ids, Table<std::uint32_t>& rank_of, Table<Emitted>& by_rank, auto&& emitted) {
      sort_pairs.clear();
      for (std::uint32_t i = 0; i < ids.size(); ++i) sort_pairs.emplace_back(ids[i], i);
      lod_detail::sort_by_id(sort_pairs, sort_scratch);
      rank_of.resize(ids.size());
      for (std::uint32_t r = 0; r < sort_pairs.size(); ++r) {
        rank_of[sort_pairs[r].second] = r;
        by_rank.push_back(emitted(sort_pairs[r].second));
      }
    };
    rank(leaf_id, leaf_rank, rank_leaf, [&](std::uint32_t j) { return Emitted{leaf_id[j], leaf_pool[j], leaf_place[j]}; });
    rank(id, k_rank, rank_interior, [&](std::uint32_t k) { return Emitted{id[k], pool[k], slot[k]}; });
    sort_pairs = {};
    sort_scratch = {};
  }
};

// Per-call arrays, kept between calls so a warm cutter does not allocate.
struct LodCutter::Scratch {
  std::vector<std::uint32_t> key;     // view error (float bits), with the hysteresis bonus
  std::vector<float> p;               // effective priority; < 0: excluded (not in the cut)
  std::vector<std::pair<std::uint32_t, std::uint32_t>> mixed;  // mixed nodes and their refinement's size
  std::vector<std::uint8_t> mark;     // kExcludedAll / kExcludedMixed
  std::vector<std::uint32_t> marked;  // the nodes with a mark, ascending
  std::vector<std::uint8_t> refined;  // this call
  std::vector<std::uint8_t> was_refined;    // the previous call (hysteresis)
  std::uint64_t was_refined_generation{0};  // layout generation was_refined is indexed for
  std::vector<std::int64_t> hist;
  std::vector<std::uint32_t> bucket;  // the nodes of the bucket where the budget runs out
  std::vector<std::uint32_t> heap;
  std::vector<std::uint32_t> excluded_leaves;  // pool indices, sorted: objects of one leaf
  std::vector<std::uint64_t> leaf_bits, interior_bits;  // what the cut emits, by rank
  std::vector<std::uint32_t> refined_k;
  std::vector<std::uint32_t> change_ranks;  // merge_changes: the marked ranks, ascending
  // The last cut (what last() returns) and what it was made for: the next cut on the same
  // layout and exclusions is that one with the changes of the nodes whose refinement flipped.
  LodCut own, next;
  bool own_incremental_base{false};  // own came from the refinement flags in was_refined
  std::vector<ObjectId> own_excluded;  // sorted, unique
  std::vector<ObjectId> excluded_now;
};

struct LodCutLayouts::Impl {
  std::mutex mutex;
  std::shared_ptr<const LodCutter::Layout> latest;
  // The layout before the latest, kept so the next build reuses its memory once no cutter
  // holds it: built on an update's worker thread, a layout's tens of megabytes otherwise came
  // fresh from that thread's arena in some epochs (5-15k page faults at a million leaves).
  std::shared_ptr<LodCutter::Layout> spare;
  std::uint64_t builds{0}, reuses{0};
  // The layout of h's present generation, built under the mutex unless it is the latest.
  std::shared_ptr<const LodCutter::Layout> latest_for(const LodHierarchy& h) {
    std::lock_guard lock(mutex);
    if (!latest || latest->hierarchy != &h || latest->generation != h.generation()) {
      // Only this object can hand the spare out, so a count of one cannot rise meanwhile.
      const bool reuse = spare && spare.use_count() == 1;
      std::shared_ptr<LodCutter::Layout> fresh = reuse ? std::move(spare) : std::make_shared<LodCutter::Layout>();
      reuses += reuse;
      fresh->build(h);
      spare = std::const_pointer_cast<LodCutter::Layout>(std::move(latest));
      latest = std::move(fresh);
      ++builds;
    }
    return latest;
  }
};

LodCutLayouts::LodCutLayouts() : impl_(std::make_unique<Impl>()) {}
LodCutLayouts::~LodCutLayouts() = default;

std::uint64_t LodCutLayouts::builds() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->builds;
}

std::uint64_t LodCutLayouts::reuses() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->reuses;
}

void LodCutLayouts::prepare(const LodHierarchy& hierarchy) { (void)impl_->latest_for(hierarchy); }

LodCutter::LodCutter(SelectorConfig config) : config_(config), scratch_(std::make_unique<Scratch>()) {}

void LodCutter::share_layouts(std::shared_ptr<LodCutLayouts> layouts) { layouts_ = std::move(layouts); }
LodCutter::LodCutter(LodCutter&&) noexcept = default;
LodCutter& LodCutter::operator=(LodCutter&&) noexcept = default;
LodCutter::~LodCutter() = default;

void LodCutter::clear_previous() {
  refined_prev_.clear();
  scratch_->was_refined.clear();
  scratch_->was_refined_generation = 0;
  scratch_->own_incremental_base = false;
}

Expected<LodCut> LodCutter::cut(const LodHierarchy& h, const ClientPose& pose, std::size_t budget,
                                std::span<const ObjectId> excluded) {
  if (Status st = cut_in_place(h, pose, budget, excluded); !st) return st.error();
  return scratch_->own;
}

Status LodCutter::cut_into(LodCut& out, const LodHierarchy& h, const ClientPose& pose, std::size_t budget,
                           std::span<const ObjectId> excluded) {
  Status st = cut_in_place(h, pose, budget, excluded);
  out = scratch_->own;
  return st;
}

const LodCut& LodCutter::last() const { return scratch_->own; }

Status LodCutter::cut_in_place(const LodHierarchy& h, const ClientPose& pose, std::size_t budget,
                               std::span<const ObjectId> excluded) {
  Scratch& S = *scratch_;
  LodCut& out = S.own;
  // The previous cut stays in `out` until this one is written: the incremental path reads it.
  const bool had_base = S.own_incremental_base;
  S.own_incremental_base = false;
  auto clear_output = [&] {
    out.nodes.clear();
    out.ids.clear();
    out.places.clear();
    out.leaves = out.interior = 0;
  };
  out.refined = out.retained = 0;
  out.layout_rebuilt = false;
  if (Status st = validate_client_pose(pose); !st) {
    clear_output();
    return st;
  }
  if (Status st = validate_selector_config(config_); !st) {
    clear_output();
    return st;
  }
  S.excluded_now.assign(excluded.begin(), excluded.end());
  std::sort(S.excluded_now.begin(), S.excluded_now.end(),
            [](ObjectId a, ObjectId b) { return to_underlying(a) < to_underlying(b); });
  S.excluded_now.erase(std::unique(S.excluded_now.begin(), S.excluded_now.end()), S.excluded_now.end());
  out.layout_rebuilt = !layout_ || layout_->hierarchy != &h || layout_->generation != h.generation();
  if (out.layout_rebuilt) {
    // The hysteresis state outlives the layout by id (a pool entry reused by the update
    // never inherits the bonus): the previous cut's refined nodes, read off the old layout.
    refined_prev_.clear();
    if (layout_ && S.was_refined_generation == layout_->generation)
      for (std::uint32_t k = 0; k < S.was_refined.size(); ++k)
        if (S.was_refined[k]) refined_prev_.emplace_back(layout_->pool[k], layout_->id[k]);
    if (layouts_) {
      layout_ = layouts_->impl_->latest_for(h);
    } else {
      // Its own: the old one's memory is reused (nobody else holds it).
      std::shared_ptr<Layout> own = std::const_pointer_cast<Layout>(std::move(layout_));
      if (!own) own = std::make_shared<Layout>();
      own->build(h);
      layout_ = std::move(own);
    }
  }
  const Layout& L = *layout_;
  const std::size_t n = L.size();
  const std::size_t leaves = L.leaf_rank.size();

  std::size_t emitted = 0;  // nodes marked for the cut
  S.leaf_bits.assign((leaves + 63) / 64, 0);
  S.interior_bits.assign((n + 63) / 64, 0);
  auto emit_leaf = [&](std::uint32_t j) {
    const std::uint32_t r = L.leaf_rank[j];
    S.leaf_bits[r >> 6] |= std::uint64_t{1} << (r & 63);
    ++emitted;
  };
  auto emit_interior = [&](std::uint32_t k) {
    const std::uint32_t r = L.k_rank[k];
    S.interior_bits[r >> 6] |= std::uint64_t{1} << (r & 63);
    ++emitted;
  };
  // Writes the marked nodes out in id order: leaves, then interior nodes.
  auto write_out = [&] {
    out.nodes.resize(emitted);
    out.ids.resize(emitted);
    out.places.resize(emitted);
    std::size_t i = 0;
    auto scan = [&](const std::vector<std::uint64_t>& marks, const Layout::Table<Layout::Emitted>& by_rank) {
      for (std::size_t w = 0; w < marks.size(); ++w)
        for (std::uint64_t bits = marks[w]; bits != 0; bits &= bits - 1) {
          const Layout::Emitted& e = by_rank[w * 64 + static_cast<std::size_t>(std::countr_zero(bits))];
          out.nodes[i] = e.pool;
          out.ids[i] = e.id;
          out.places[i] = e.place;
          ++i;
        }
    };
    scan(S.leaf_bits, L.rank_leaf);
    out.leaves = i;
    scan(S.interior_bits, L.rank_interior);
    out.interior = i - out.leaves;
  };
  // This cut's refinements are the next call's hysteresis state: flags on this layout.
  auto finish = [&](std::span<const std::uint32_t> refined_k) {
    S.was_refined.assign(n, 0);
    for (std::uint32_t k : refined_k) S.was_refined[k] = 1;
    S.was_refined_generation = L.generation;
    out.refined = refined_k.size();
  };

  // The excluded objects' subtrees, and every node above them (the mixed ones).
  // Only the nodes marked last time are cleared: a pose update without a query touches none.
  if (S.mark.size() != n || out.layout_rebuilt)
    S.mark.assign(n, 0);
  else
    for (std::uint32_t k : S.marked) S.mark[k] = 0;
  S.marked.clear();
  auto set_mark = [&](std::uint32_t k, std::uint8_t m) {
    if (S.mark[k] == 0) S.marked.push_back(k);
    S.mark[k] = m;
  };
  S.excluded_leaves.clear();
  bool root_excluded = false;
  for (ObjectId o : excluded) {
    const std::uint32_t r = h.object_root(o);
    if (r == kNoLodNode) continue;
    std::uint32_t up;
    if (h.node(r).leaf) {
      S.excluded_leaves.push_back(r);
      if (r == L.root_leaf) root_excluded = true;
      up = h.node(r).parent == kNoLodNode ? kNone : L.k_of_pool[h.node(r).parent];
    } else {
      const std::uint32_t k = L.k_of_pool[r];
      set_mark(k, kExcludedAll);
      up = L.parent[k];
    }
    for (; up != kNone && S.mark[up] != kExcludedMixed; up = L.parent[up]) set_mark(up, kExcludedMixed);
  }
  std::sort(S.marked.begin(), S.marked.end());
  std::sort(S.excluded_leaves.begin(), S.excluded_leaves.end());
  auto leaf_excluded = [&](std::uint32_t j) {
    return std::binary_search(S.excluded_leaves.begin(), S.excluded_leaves.end(), L.rank_leaf[L.leaf_rank[j]].pool);
  };

  if (budget == 0 || h.root() == kNoLodNode || (L.root_leaf == kNone && S.mark[0] == kExcludedAll)) {
    clear_output();
    finish({});
    return Ok{};
  }
  if (L.root_leaf != kNone) {  // a hierarchy of one leaf
    clear_output();
    if (!root_excluded) {
      const LodNode& leaf = h.node(L.root_leaf);
      out.nodes.push_back(L.root_leaf);
      out.ids.push_back(to_underlying(leaf.id));
      out.places.push_back(h.leaf_source(leaf));
      out.leaves = 1;
    }
    finish({});
    return Ok{};
  }

  // Hysteresis flags for this layout: the previous call's, carried by id when the layout is new.
  if (S.was_refined_generation != L.generation || S.was_refined.size() != n) {
    S.was_refined.assign(n, 0);
    for (const auto& [pool_index, id] : refined_prev_)
      if (pool_index < L.k_of_pool.size())
        if (const std::uint32_t k = L.k_of_pool[pool_index]; k != kNone && L.id[k] == id) S.was_refined[k] = 1;
    S.was_refined_generation = L.generation;
  }

  // View errors, then effective priorities in breadth-first order (parents first): one
  // branch-free pass each. A mixed node's key is +inf (always refined), an excluded node's -1,
  // which the min carries down its subtree.
  const select_detail::ViewParams view = select_detail::make_view_params(pose, config_);
  S.key.resize(n);
  select_detail::score_view_spheres(n, L.cx.data(), L.cy.data(), L.cz.data(), L.radius.data(),
                                    S.was_refined.data(), view, S.key.data());
  // Refining every mixed node leaves its children that are neither mixed nor excluded; the
  // refinement of a mixed node adds its children that are not excluded, less itself.
  std::size_t forced_cut = S.mark[0] == kExcludedMixed ? 0 : 1;
  S.mixed.clear();
  for (std::uint32_t k : S.marked) {
    if (S.mark[k] == kExcludedAll) {
      S.key[k] = std::bit_cast<std::uint32_t>(-1.0f);
    } else if (S.mark[k] == kExcludedMixed) {
      S.key[k] = std::bit_cast<std::uint32_t>(std::numeric_limits<float>::infinity());
      std::uint32_t children = 0;
      for (std::uint32_t c = L.kid_begin[k]; c < L.kid_begin[k] + L.kid_count[k]; ++c) {
        children += S.mark[c] != kExcludedAll;
        forced_cut += S.mark[c] == 0;
      }
      for (std::uint32_t j = L.leaf_begin[k]; j < L.leaf_begin[k] + L.leaf_count[k]; ++j) {
        const bool in_cut = !leaf_excluded(j);
        children += in_cut;
        forced_cut += in_cut;
      }
      S.mixed.emplace_back(k, children > 0 ? children - 1 : 0);
    }
  }
  S.p.resize(n);
  {
    const std::uint32_t* __restrict key = S.key.data();
    const std::uint32_t* __restrict parent = L.parent.data();
    float* __restrict p = S.p.data();
    // A NaN error (a sphere too far for float arithmetic from a far pose) counts as 0, as
    // the plain greedy's sphere_error has it: every p is then a number, and a node's
    // exclusion (p < 0) depends on the marks alone.
    auto error = [&](std::size_t k) {
      const float e = std::bit_cast<float>(key[k]);
      return e == e ? e : 0.0f;
    };
    p[0] = error(0);
    for (std::size_t k = 1; k < n; ++k) p[k] = std::min(error(k), p[parent[k]]);
  }
  auto& refined_k = S.refined_k;
  refined_k.clear();
  if (forced_cut > budget) {
    // Forced refinement alone overflows B: keep the B frontier nodes with the largest error.
    struct Entry {
      float key;
      std::uint64_t id;
      std::uint32_t k;     // layout index, or kNone for a leaf
      std::uint32_t leaf;  // leaf index (breadth-first)
    };
    std::vector<Entry> all;
    for (const auto& [k, d] : S.mixed) {
      refined_k.push_back(k);
      for (std::uint32_t c = L.kid_begin[k]; c < L.kid_begin[k] + L.kid_count[k]; ++c)
        if (S.mark[c] == 0) all.push_back(Entry{S.p[c], L.id[c], c, 0});
      for (std::uint32_t j = L.leaf_begin[k]; j < L.leaf_begin[k] + L.leaf_count[k]; ++j) {
        if (leaf_excluded(j)) continue;
        const Layout::Emitted& e = L.rank_leaf[L.leaf_rank[j]];
        const LodNode& leaf = h.node(e.pool);
        all.push_back(Entry{sphere_error(view, leaf.centre, leaf.radius), e.id, kNone, j});
      }
    }
    std::sort(all.begin(), all.end(),
              [](const Entry& a, const Entry& b) { return a.key > b.key || (a.key == b.key && a.id < b.id); });
    all.resize(budget);
    for (const Entry& e : all) {
      if (e.k == kNone)
        emit_leaf(e.leaf);
      else
        emit_interior(e.k);
    }
    write_out();
    finish(refined_k);
    return Ok{};
  }

  // Refinement counts per bucket of p; from the top, every bucket that fits whole is refined
  // without ordering it (a node's ancestors have p at least its own, so they are refined too).
  S.hist.assign(kBuckets, 0);
  for (std::uint32_t k = 0; k < n; ++k)
    if (S.p[k] >= 0.0f) S.hist[bucket_of(S.p[k])] += L.delta[k];
  for (const auto& [k, d] : S.mixed) S.hist[kBuckets - 1] += d - std::int64_t{L.delta[k]};
  std::size_t count = 1;
  std::uint32_t boundary = kBuckets;  // the bucket where the budget runs out; kBuckets: none does
  for (std::uint32_t b = kBuckets; b-- > 0;) {
    if (count + static_cast<std::size_t>(S.hist[b]) > budget) {
      boundary = b;
      break;
    }
    count += static_cast<std::size_t>(S.hist[b]);
  }
  // Greedy order: p descending, then shallower, then the lower id.
  auto after = [&](std::uint32_t a, std::uint32_t b) {
    if (S.p[a] != S.p[b]) return S.p[a] < S.p[b];
    if (L.depth[a] != L.depth[b]) return L.depth[a] > L.depth[b];
    return L.id[a] > L.id[b];
  };
  S.refined.resize(n);
  S.bucket.clear();
  {
    // Bucket numbers compare as the floats' bits do; a negative p (excluded) has the sign bit,
    // so its bits are above every bucket: excluded by the upper bound.
    const std::uint32_t first = boundary == kBuckets ? 0 : (boundary + 1) << kBucketShift;
    const std::uint32_t at = boundary << kBucketShift;
    const std::uint32_t* __restrict pb = reinterpret_cast<const std::uint32_t*>(S.p.data());
    for (std::uint32_t k = 0; k < n; ++k) {
      const std::uint32_t bits = pb[k];
      const bool refine = bits >= first && bits <= 0x7F800000u;
      S.refined[k] = refine;
      if (refine) refined_k.push_back(k);
      if (bits - at < (1u << kBucketShift) && boundary != kBuckets) S.bucket.push_back(k);
    }
  }
  if (boundary != kBuckets) {
    // A node refines when its parent did and its children fit (the greedy's rule, in order).
    auto fits = [&](std::uint32_t k) { return S.p[k] >= 0.0f && count + L.delta[k] <= budget; };
    auto refine = [&](std::uint32_t k) {
      S.refined[k] = 1;
      refined_k.push_back(k);
      count += L.delta[k];
    };
    std::sort(S.bucket.begin(), S.bucket.end(), [&](std::uint32_t a, std::uint32_t b) { return after(b, a); });
    for (std::uint32_t k : S.bucket)
      if ((k == 0 || S.refined[L.parent[k]]) && fits(k)) refine(k);
    // Below the boundary only nodes whose children still fit can refine: a small heap over
    // the frontier's, and their children as they open.
    S.heap.clear();
    if (count < budget)
      for (std::uint32_t k = 1; k < n; ++k)
        if (S.p[k] >= 0.0f && bucket_of(S.p[k]) < boundary && S.refined[L.parent[k]] && fits(k)) S.heap.push_back(k);
    std::make_heap(S.heap.begin(), S.heap.end(), after);
    while (!S.heap.empty() && count < budget) {
      std::pop_heap(S.heap.begin(), S.heap.end(), after);
      const std::uint32_t k = S.heap.back();
      S.heap.pop_back();
      if (!fits(k)) continue;
      refine(k);
      for (std::uint32_t c = L.kid_begin[k]; c < L.kid_begin[k] + L.kid_count[k]; ++c) {
        if (!fits(c)) continue;
        S.heap.push_back(c);
        std::push_heap(S.heap.begin(), S.heap.end(), after);
      }
    }
  }

  // The cut: what refined nodes open and do not refine themselves. When the last cut came
  // from the flags in was_refined on this layout with the same exclusions, only the nodes
  // whose refinement flipped, and their children, can enter or leave it: that cut is merged
  // with those changes (a pose update flips a few percent of the nodes). Else every refined
  // node is opened.
  const bool incremental = had_base && !out.layout_rebuilt && S.was_refined_generation == L.generation &&
                           S.was_refined.size() == n && S.own_excluded == S.excluded_now &&
                           out.leaves + out.interior == out.nodes.size() && merge_changes(budget);
  if (!incremental) {
    if (!S.refined[0]) emit_interior(0);
    for (std::uint32_t k : refined_k) {
      out.retained += S.was_refined[k];
      for (std::uint32_t c = L.kid_begin[k]; c < L.kid_begin[k] + L.kid_count[k]; ++c)
        if (!S.refined[c] && S.p[c] >= 0.0f) emit_interior(c);
      const bool mixed = S.mark[k] == kExcludedMixed;
      for (std::uint32_t j = L.leaf_begin[k]; j < L.leaf_begin[k] + L.leaf_count[k]; ++j)
        if (!mixed || !leaf_excluded(j)) emit_leaf(j);
    }
    write_out();
  }
  S.own_incremental_base = true;
  S.own_excluded = S.excluded_now;
  // The flags just set are the next call's hysteresis state on this layout.
  S.was_refined.swap(S.refined);
  S.was_refined_generation = L.generation;
  out.refined = refined_k.size();
  return Ok{};
}

bool LodCutter::merge_changes(std::size_t budget) {
  const Layout& L = *layout_;
  Scratch& S = *scratch_;
  const LodCut& out = S.own;
  const std::size_t n = L.size();
  const std::uint8_t* now = S.refined.data();
  const std::uint8_t* was = S.was_refined.data();
  // Nodes whose membership flips, marked by rank (the bitmaps the full path would fill are
  // still clear): scanning them gives the changes in id order without a sort.
  std::uint64_t* leaf_bits = S.leaf_bits.data();
  std::uint64_t* interior_bits = S.interior_bits.data();
  std::size_t newly_refined = 0, changes = 0;
  auto interior_in = [&](const std::uint8_t* f, std::uint32_t k) {
    return k == 0 ? !f[0] : f[L.parent[k]] && !f[k] && S.p[k] >= 0.0f;
  };
  auto change = [&](std::uint32_t k) {
    if (interior_in(was, k) == interior_in(now, k)) return;
    const std::uint32_t r = L.k_rank[k];
    interior_bits[r >> 6] |= std::uint64_t{1} << (r & 63);
    ++changes;
  };
  // A flipped node: itself, its interior children whose own flag stayed (a flipped child is
  // visited by itself), and its leaf children, which are in the cut exactly when it is refined.
  auto visit = [&](std::uint32_t k) {
    newly_refined += now[k] != 0;
    change(k);
    for (std::uint32_t c = L.kid_begin[k]; c < L.kid_begin[k] + L.kid_count[k]; ++c)
      if ((now[c] != 0) == (was[c] != 0)) change(c);
    const bool mixed = S.mark[k] == kExcludedMixed;
    for (std::uint32_t j = L.leaf_begin[k]; j < L.leaf_begin[k] + L.leaf_count[k]; ++j) {
      const std::uint32_t r = L.leaf_rank[j];
      if (!mixed || !std::binary_search(S.excluded_leaves.begin(), S.excluded_leaves.end(), L.rank_leaf[r].pool)) {
        leaf_bits[r >> 6] |= std::uint64_t{1} << (r & 63);
        ++changes;
      }
    }
  };
  std::size_t k = 0;
  for (; k + 8 <= n; k += 8) {  // most words of flags are unchanged
    std::uint64_t a, b;
    std::memcpy(&a, now + k, 8);
    std::memcpy(&b, was + k, 8);
    if (a == b) continue;
    for (std::size_t i = k; i < k + 8; ++i)
      if ((now[i] != 0) != (was[i] != 0)) visit(static_cast<std::uint32_t>(i));
  }
  for (; k < n; ++k)
    if ((now[k] != 0) != (was[k] != 0)) visit(static_cast<std::uint32_t>(k));

  // Merge: a changed node that the last cut holds leaves it, any other enters.
  LodCut& next = S.next;
  next.nodes.resize(out.nodes.size() + changes);
  next.ids.resize(next.nodes.size());
  next.places.resize(next.nodes.size());
  std::size_t t = 0;
  // The changed ranks are listed first, so the entries they name (scattered over tables of
  // 16 MB at a million leaves, a cache miss each) are loaded a few changes ahead.
  auto merge = [&](std::size_t a, std::size_t to, const std::vector<std::uint64_t>& marks,
                   const Layout::Table<Layout::Emitted>& by_rank) {
    auto& ranks = S.change_ranks;
    ranks.clear();
    for (std::size_t w = 0; w < marks.size(); ++w)
      for (std::uint64_t bits = marks[w]; bits != 0; bits &= bits - 1)
        ranks.push_back(static_cast<std::uint32_t>(w * 64 + static_cast<std::size_t>(std::countr_zero(bits))));
    // Local pointers and counters: a store through the outputs may alias anything of their
    // types, a captured counter and the vectors' own pointers included, which the loop then
    // reloaded after every store.
    const std::uint32_t* in_nodes = out.nodes.data();
    const std::uint64_t* in_ids = out.ids.data();
    const std::uint32_t* in_places = out.places.data();
    std::uint32_t* to_nodes = next.nodes.data();
    std::uint64_t* to_ids = next.ids.data();
    std::uint32_t* to_places = next.places.data();
    const std::size_t room = next.nodes.size();
    const std::uint32_t* rank = ranks.data();
    const std::size_t changed = ranks.size();
    const Layout::Emitted* table = by_rank.data();
    std::size_t u = t;
    constexpr std::size_t kAhead = 16;
    for (std::size_t c = 0; c < std::min(kAhead, changed); ++c) __builtin_prefetch(table + rank[c]);
    for (std::size_t c = 0; c < changed; ++c) {
      if (c + kAhead < changed) __builtin_prefetch(table + rank[c + kAhead]);
      const Layout::Emitted& e = table[rank[c]];
      const std::uint64_t id = e.id;
      for (; a < to && in_ids[a] < id; ++a, ++u) {
        to_nodes[u] = in_nodes[a];
        to_ids[u] = in_ids[a];
        to_places[u] = in_places[a];
      }
      if (a < to && in_ids[a] == id) {
        ++a;  // leaves
      } else {
        if (u == room) return false;
        to_nodes[u] = e.pool;
        to_ids[u] = id;
        to_places[u] = e.place;
        ++u;
      }
    }
    for (; a < to; ++a, ++u) {
      to_nodes[u] = in_nodes[a];
      to_ids[u] = in_ids[a];
      to_places[u] = in_places[a];
    }
    t = u;
    return true;
  };
  // Should the changes not fit the last cut (a bug), the full path runs on clear bitmaps.
  auto fail = [&] {
    std::fill(S.leaf_bits.begin(), S.leaf_bits.end(), 0);
    std::fill(S.interior_bits.begin(), S.interior_bits.end(), 0);
    return false;
  };
  if (!merge(0, out.leaves, S.leaf_bits, L.rank_leaf)) return fail();
  const std::size_t leaves = t;
  if (!merge(out.leaves, out.nodes.size(), S.interior_bits, L.rank_interior) || t > budget) return fail();
  next.nodes.resize(t);
  next.ids.resize(t);
  next.places.resize(t);
  next.leaves = leaves;
  next.interior = t - leaves;
  next.refined = out.refined;
  next.retained = S.refined_k.size() - newly_refined;
  next.layout_rebuilt = out.layout_rebuilt;
  std::swap(S.own, S.next);
  return true;
}

}  // namespace gauss
