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

  // 2. The sorted order: (tree, code, id), by radix passes (sort_entries; std::sort of the
  // entries was a tenth of the build).
  order_.resize(leaves);
  for (std::size_t j = 0; j < leaves; ++j)
    order_[j] = Entry{tree_of(leaf_fields_[j].object), std::uint32_t(j), morton(leaf_fields_[j].position)};
  sort_entries(order_);
  std::vector<std::uint32_t> tree_at;  // the trees, in order
  for (const Entry& e : order_)
    if (tree_at.empty() || tree_at.back() != e.tree) tree_at.push_back(e.tree);

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
