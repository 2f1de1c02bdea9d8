#pragma once
// Constants and bit tricks shared by the LoD hierarchy's translation units.
#include <algorithm>
#include <cstddef>
#include <cstdint>

namespace gauss::lod_detail {

// Tree tags of InteriorKey::tree. Object trees use the object id (0..2^31-1), so these sort
// after every object: the background's leaves come last in the sorted leaf order.
inline constexpr std::uint32_t kBackgroundTree = 0xFFFFFFF0u;
inline constexpr std::uint32_t kObjectsTree = 0xFFFFFFF1u;
inline constexpr std::uint32_t kRootTree = 0xFFFFFFF2u;

// Leaves a full build asks the cache for at once: their nodes and fields (~230 KB) stay in
// L2 until the merges under the cell have read them.
inline constexpr std::size_t kWarmLeaves = 2048;

// Keeps a value computed only for its loads' effect on the cache (warm_leaves).
inline void keep(std::uint32_t v) { asm volatile("" : : "r"(v)); }

// Cells of more leaves than this have their octants sized from the old subtree's leaf counts
// in an update (build_cell); smaller ones, a few cache lines of the order, are searched.
inline constexpr std::size_t kSizedFrom = 32;

// Marks a new id in leaf_index_ while an update is validated (rolled back on failure).
inline constexpr std::uint32_t kPendingLeaf = 0xFFFFFFFEu;

// Octree depth of a group tree: 21 bits per axis = a 63-bit Morton code.
inline constexpr int kGroupLevels = 21;
// Radix-8 levels of the objects tree over object ids (< 2^31 <= 8^11).
inline constexpr int kObjectsLevels = 11;

// Spreads the low 21 bits of v to every third bit (bit i -> bit 3i).
constexpr std::uint64_t spread3(std::uint64_t v) {
  v &= 0x1FFFFFull;
  v = (v | (v << 32)) & 0x1F00000000FFFFull;
  v = (v | (v << 16)) & 0x1F0000FF0000FFull;
  v = (v | (v << 8)) & 0x100F00F00F00F00Full;
  v = (v | (v << 4)) & 0x10C30C30C30C30C3ull;
  v = (v | (v << 2)) & 0x1249249249249249ull;
  return v;
}

constexpr std::uint64_t morton3(std::uint64_t x, std::uint64_t y, std::uint64_t z) {
  return spread3(x) | (spread3(y) << 1) | (spread3(z) << 2);
}

// The first element of [first, last) for which `pred` is false, `pred` being true on a prefix:
// std::partition_point, found by galloping from `first`. A binary search over the whole range
// starts with probes far away (a cache miss each, in an order of a million entries); the
// answers sought here lie near the start, and galloping costs what that distance costs.
template <class It, class Pred>
It gallop_partition_point(It first, It last, Pred pred) {
  if (first == last || !pred(*first)) return first;
  It lo = first;  // pred(*lo)
  std::ptrdiff_t step = 1;
  while (step < last - lo && pred(lo[step])) {
    lo += step;
    step *= 2;
  }
  return std::partition_point(lo + 1, lo + std::min(step, last - lo), pred);
}

static_assert(morton3(1, 0, 0) == 1 && morton3(0, 1, 0) == 2 && morton3(0, 0, 1) == 4);
static_assert(morton3(0x1FFFFF, 0x1FFFFF, 0x1FFFFF) == (std::uint64_t{1} << 63) - 1);

}  // namespace gauss::lod_detail

#include <array>
#include <cassert>
#include <exception>
#include <span>
#include <vector>

#include "gauss/engine/lod_hierarchy.h"
#include "gauss/engine/sym_eigen3.h"

namespace gauss {

// One tree's pass of an update: which tree, how deep its codes go, which codes changed, and
// where retired nodes and the report go.
struct LodHierarchy::TreeBuild {
  std::uint32_t tree{0};
  int levels{0};
  LodUpdateReport* report{nullptr};
  std::vector<std::uint32_t>* retired{nullptr};  // interior nodes to free once the update is done
  std::vector<std::uint32_t>* stack{nullptr};    // children under construction
  std::vector<LodMoments>* moments{nullptr};     // merge scratch
  std::vector<glm::dvec3>* rest{nullptr};
  // Incremental updates: interior nodes made or kept, merged after the descent (in this
  // order: children first) instead of as they are made. Null in a full build, which merges
  // each cell while its leaves are in cache.
  std::vector<DeferredMerge>* deferred{nullptr};
  // A full build visits every leaf of the sorted order once, in order, so the first cell of
  // at most kWarmLeaves leaves loads all of them (warm_leaves); warmed_to is how far it has.
  // False in incremental updates (which visit few leaves).
  bool full{false};
  // An update of a group tree: items are leaves and the descent is given each cell's changes,
  // so octants may be sized from the old subtree's leaf counts (an objects tree's items are
  // trees, whose leaf counts are not item counts).
  bool sized{false};
  const Entry* warmed_to{nullptr};
  // Merged nodes whose records still want their geometry: their covariances are decomposed
  // kSymEigen3Lanes at a time (flush_geometry), whose divisions and roots then overlap.
  // Everything else of the merge is done, the record's appearance included (a parent reads
  // its children's SH rest). `appearance_changed`: a kept node's appearance bits changed.
  struct PendingGeometry {
    std::uint32_t node;
    bool kept;
    bool appearance_changed;
  };
  std::array<PendingGeometry, kSymEigen3Lanes> pending{};
  std::size_t pending_count{0};

  TreeBuild() = default;
  TreeBuild(const TreeBuild&) = default;
  TreeBuild& operator=(const TreeBuild&) = default;
  // Every merge's geometry was given (flush_geometry) unless an exception cut the update short.
  ~TreeBuild() { assert(pending_count == 0 || std::uncaught_exceptions() > 0); }
};

// What changed within one cell, carried down the descent and split by octant at each level.
// `dirty`: the codes of changed leaves (old and new places) in the cell, sorted; a cell
// without any keeps its old subtree. (Asked of the tree's whole list, each child's answer was
// a binary search over thousands of codes: 3 % of scattered churn.) `fresh` and
// `leaving`: the entries entering and leaving the sorted order in the cell of a group tree
// (sorted by code): with the old subtree's leaf counts they give the cell's octant sizes.
struct LodHierarchy::CellChanges {
  std::span<const Entry> fresh;
  std::span<const Entry> leaving;
  std::span<const std::uint64_t> dirty;
};

}  // namespace gauss
