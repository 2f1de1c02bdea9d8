// The full build: update() of a hierarchy without leaves. The general path would look every
// Gaussian up three times in the id index, compute its moments only to learn it is usable,
// note a changed cell per leaf and sort those, and merge a sorted run into an empty order;
// here one pass over the input validates, classifies and stores the leaves, one sort orders
// them, and the trees are built by the same recursion (every cell new, so none of the diffing
// applies). The result is the general path's, node for node: same pool layout, interior
// serials in the same order, bit-identical records, the same report (a test builds both ways).
#include <algorithm>
#include <bit>
#include <cmath>
#include <string>

#include "id_sort.h"
#include "lod_internal.h"
#include "lod_leaf_moments.h"

namespace gauss {

using lod_detail::kPendingLeaf;

void LodHierarchy::clear_pools() {
  // Without a leaf no node is live (each interior node stands for >= 1 leaf), so every pool
  // entry is dead and the pools start over. Serials and the cube stay: ids are never reused,
  // and codes stay comparable between epochs.
  nodes_.clear();
  free_nodes_.clear();
  children_.clear();
  children_spare_.clear();
  children_garbage_ = 0;
  leaf_fields_.clear();
  leaf_rest_.clear();
  leaf_source_.clear();
  free_leaf_slots_.clear();
  leaf_index_ = detail::IdIndex{};
  records_.clear();
  moments_.clear();
  keys_.clear();
  free_interior_slots_.clear();
  interior_live_ = 0;
  order_.clear();
  touch_stamp_.clear();
  group_roots_.clear();
  objects_root_ = kNoLodNode;
  root_ = kNoLodNode;
  input_nodes_.clear();
}

Expected<LodUpdateReport> LodHierarchy::build_from_empty(std::span<const Gaussian* const> gaussians,
                                                         const Gaussian* base) {
  const std::size_t n = gaussians.size();
  const std::size_t rc = std::size_t(rest_count_);
  clear_pools();
  auto fail = [&](std::string message) -> Expected<LodUpdateReport> {
    clear_pools();  // as it was: empty
    return Error{std::move(message)};
  };
  auto id_text = [](std::uint64_t id) { return std::to_string(id); };

  // 1. One pass in input order, checks in the general path's order (top bit, then duplicate:
  // an unusable Gaussian counts for duplicates too). Leaf j is node j and leaf slot j, as the
  // general path allocates them from empty pools.
  leaf_index_.reserve(n);
  nodes_.reserve(n + n / 2);  // interior nodes: ~1 per 3 leaves at 8 leaves per cell
  touch_stamp_.reserve(n + n / 2);
  // Leaf pools with room for later inserts (an exact fit would copy them all at the first).
  const std::size_t room = n + n / 8;
  leaf_fields_.reserve(room);
  leaf_rest_.reserve(room * rc);
  leaf_source_.reserve(room);
  if (base) input_nodes_.assign(n, kNoLodNode);
  std::vector<std::uint64_t> skipped;
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(std::numeric_limits<double>::lowest());
  constexpr std::size_t kBlock = 64;  // Gaussians whose lines are loaded together
  for (std::size_t k = 0; k < n; ++k) {
    if (k % kBlock == 0) {
      // The input's lines the pass reads (fields, id), loaded back to back so the misses
      // overlap (see warm_leaves), then the index cells of their ids.
      const std::size_t end = std::min(n, k + kBlock);
      std::uint32_t acc = 0;
      for (std::size_t i = k; i < end; ++i)
        acc += std::bit_cast<std::uint32_t>(gaussians[i]->position.x) + std::uint32_t(to_underlying(gaussians[i]->id));
      lod_detail::keep(acc);
      for (std::size_t i = k; i < end; ++i) leaf_index_.prefetch(to_underlying(gaussians[i]->id));
    }
    const Gaussian& g = *gaussians[k];
    const std::uint64_t id = to_underlying(g.id);
    if (id & kLodInteriorIdBit)
      return fail("LodHierarchy: Gaussian id " + id_text(id) + " has the top bit set (reserved for interior nodes)");
    if (leaf_index_.find(id)) return fail("LodHierarchy: Gaussian id " + id_text(id) + " is given twice");
    if (lod_detail::leaf_status(g, rest_count_, config_.merge) != LodLeafStatus::Usable) {
      leaf_index_.set(id, kPendingLeaf);  // still a duplicate if it comes again
      skipped.push_back(id);
      continue;
    }
    const std::uint32_t node = std::uint32_t(nodes_.size());
    nodes_.emplace_back();
    touch_stamp_.push_back(0);
    nodes_[node].data = node;
    leaf_fields_.emplace_back();
    leaf_rest_.insert(leaf_rest_.end(), g.sh_rest.begin(), g.sh_rest.begin() + std::ptrdiff_t(rc));
    leaf_source_.push_back(base ? std::uint32_t(&g - base) : kNoLodSource);
    store_leaf(node, g);
    leaf_index_.set(id, node);
    if (base) input_nodes_[k] = node;
    lo = glm::min(lo, glm::dvec3(g.position));
    hi = glm::max(hi, glm::dvec3(g.position));
  }
  for (std::uint64_t id : skipped) leaf_index_.erase(id);
  LodUpdateReport report;
  report.skipped = skipped.size();
  const std::size_t leaves = nodes_.size();
  report.leaves_inserted = leaves;
  if (leaves == 0) return report;
  fix_cube(lo, hi);

  // 2. The sorted order: (tree, code, id). Trees by a counting sort over their ranks, each
  // tree's codes by radix passes over the bits in which they differ (stable, so equal codes
  // keep input order), then each run of equal codes (coincident leaves) by id: std::sort of
  // the entries was a tenth of the build.
  // The scratch of tens of megabytes (TableVector) lies on huge pages, as the pools do: on
  // plain vectors it came fresh from the kernel on 4 KiB pages wherever the heap had no such
  // room, about 11k page faults a build at a million leaves (LodHierarchy.Timing at SH 3).
  detail::TableVector<std::uint32_t> tree_rank(leaves);
  std::vector<std::uint32_t> trees;  // distinct trees, first seen first
  {
    detail::IdIndex seen;
    for (std::size_t j = 0; j < leaves; ++j) {
      const std::uint32_t t = tree_of(leaf_fields_[j].object);
      const std::uint32_t* r = seen.find(t);
      if (!r) {
        seen.set(t, std::uint32_t(trees.size()));
        trees.push_back(t);
        r = seen.find(t);
      }
      tree_rank[j] = *r;
    }
  }
  std::vector<std::uint32_t> by_tree(trees.size());  // first-seen index -> rank in tree order
  {
    std::vector<std::uint32_t> idx(trees.size());
    for (std::uint32_t i = 0; i < idx.size(); ++i) idx[i] = i;
    std::sort(idx.begin(), idx.end(), [&](std::uint32_t a, std::uint32_t b) { return trees[a] < trees[b]; });
    for (std::uint32_t r = 0; r < idx.size(); ++r) by_tree[idx[r]] = r;
  }
  std::vector<std::size_t> start(trees.size() + 1, 0);
  for (std::size_t j = 0; j < leaves; ++j) ++start[by_tree[tree_rank[j]] + 1];
  for (std::size_t r = 0; r < trees.size(); ++r) start[r + 1] += start[r];
  detail::TableVector<lod_detail::IdPair> pairs(leaves), scratch;
  {
    std::vector<std::size_t> at(start.begin(), start.end() - 1);
    for (std::size_t j = 0; j < leaves; ++j)
      pairs[at[by_tree[tree_rank[j]]]++] = {morton(leaf_fields_[j].position), std::uint32_t(j)};
  }
  for (std::size_t r = 0; r < trees.size(); ++r)
    lod_detail::sort_by_id(std::span<lod_detail::IdPair>(pairs).subspan(start[r], start[r + 1] - start[r]), scratch);
  detail::TableVector<std::uint64_t> ids(leaves);  // compact: the reads below in tree order hit L3
  for (std::size_t j = 0; j < leaves; ++j) ids[j] = to_underlying(nodes_[j].id);
  auto id_of = [&](std::uint32_t j) { return ids[j]; };
  for (std::size_t r = 0; r < trees.size(); ++r) {
    for (std::size_t i = start[r]; i < start[r + 1];) {
      std::size_t e = i + 1;
      while (e < start[r + 1] && pairs[e].first == pairs[i].first) ++e;
      if (e - i > 1)
        std::sort(pairs.begin() + std::ptrdiff_t(i), pairs.begin() + std::ptrdiff_t(e),
                  [&](const auto& a, const auto& b) { return id_of(a.second) < id_of(b.second); });
      i = e;
    }
  }
  std::vector<std::uint32_t> tree_at(trees.size());  // rank -> tree
  for (std::size_t i = 0; i < trees.size(); ++i) tree_at[by_tree[i]] = trees[i];
  order_.resize(leaves);
  for (std::size_t r = 0; r < trees.size(); ++r)
    for (std::size_t i = start[r]; i < start[r + 1]; ++i) {
      const std::uint32_t j = pairs[i].second;
      order_[i] = Entry{tree_at[r], j, pairs[i].first};
    }

  // 3. Every tree, all cells new.
  records_.reserve(leaves / 2);
  moments_.reserve(leaves / 2);
  keys_.reserve(leaves / 2);
  children_.reserve(leaves + leaves / 2);
  std::vector<std::pair<std::uint32_t, std::uint64_t>> dirty;  // one (tree, any code) per tree
  for (std::uint32_t t : tree_at) dirty.emplace_back(t, 0);
  std::vector<std::uint32_t> retired;  // stays empty: nothing was there
  update_trees(dirty, {}, {}, report, retired, true);
  sort_report(report);
  return report;
}

}  // namespace gauss
