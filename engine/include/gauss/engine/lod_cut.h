#pragma once
// LodCutter: a cut through a LodHierarchy (a set of nodes that covers every leaf it stands
// for exactly once) of at most B nodes, chosen by view-dependent error. The host sends the
// cut instead of B leaves, so what the budget cannot hold in detail is still there, coarse.
//
// Error of a node: its angular radius (bounding-sphere radius / distance, the distance floored
// at SelectorConfig::near_distance) times the selector's facing factor (1 in the frustum,
// ramping to out_of_view_weight over margin_deg outside it; selector.h). Refinement is greedy
// from the root: the frontier node with the largest error is replaced by its children while
// the cut stays within B; a node whose children do not fit stays as it is, and smaller ones
// behind it may still refine. Ties go to the shallower node, then the lower id, so a cut is a
// function of the hierarchy, the pose, B and the previous cut.
//
// Hysteresis (SelectorConfig::retention_bonus): a node refined in the previous cut has its
// error multiplied by 1 + bonus, so a small pose change does not coarsen and refine the same
// nodes back and forth. clear_previous forgets it, as the selector's clear_resident does.
//
// Excluded objects (a query's targets, whose leaves the semantic reservation keeps at full
// detail): a node whose leaves all belong to them is left out of the cut; a node that mixes
// them with other leaves is always refined, or it would show the target a second time,
// coarse. The hierarchy gives each object its own subtree, so only the nodes on the paths
// from the root to the targets' subtrees mix; refining them is forced, and when that alone
// leaves more than B nodes the cut keeps the B with the largest error.
//
// The greedy order is the order of effective priority p(n) = min(error(n), p(parent)): a
// child whose error exceeds its parent's is refined right after it, so the pops of a frontier
// heap come out in p order (ties: shallower first, then the lower id). The cutter uses that
// to skip the heap. Per call it computes p for every interior node over a copy of the tree in
// breadth-first order (structure of arrays, built once per hierarchy generation), histograms
// the refinement counts by p's top bits, refines every bucket that fits whole without
// ordering it, sorts only the bucket where the budget runs out, and finishes with a small
// heap over the frontier nodes that can still fit. Cost: O(I) sequential work for I interior
// nodes plus the sort of one bucket, instead of O(K log K) scattered reads; the layout
// (O(N), once after each hierarchy update) is paid by the first cut that sees the update.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "gauss/engine/ids.h"
#include "gauss/engine/lod_hierarchy.h"
#include "gauss/engine/result.h"
#include "gauss/engine/selector.h"

namespace gauss {

struct LodCut {
  // Pool indices of the cut's nodes: its leaves in ascending id order, then its interior
  // nodes in ascending id order (what a Selection wants, without a sort).
  std::vector<std::uint32_t> nodes;
  // Parallel to nodes: the node's id, and where its value lies: a leaf's leaf_source(), an
  // interior node's record_slot(). A caller assembling a selection reads these instead of
  // the pool (a cache miss per node at a million leaves).
  std::vector<std::uint64_t> ids;
  std::vector<std::uint32_t> places;
  std::size_t leaves{0};             // how many of them are leaves
  std::size_t interior{0};           // and interior nodes
  std::size_t refined{0};            // nodes replaced by their children (the work)
  std::size_t retained{0};           // refined nodes that were refined in the previous cut
  bool layout_rebuilt{false};        // the hierarchy changed since the last cut: its layout was rebuilt
};

// The breadth-first copies of a hierarchy that cuts read, built once per hierarchy generation
// and shared by every cutter given this (the sessions reading one shared hierarchy): without
// it each cutter builds its own, in time and memory per session. Thread-safe: the first cutter
// to see a generation builds its copy while the others wait.
class LodCutLayouts {
 public:
  LodCutLayouts();
  ~LodCutLayouts();
  LodCutLayouts(const LodCutLayouts&) = delete;
  LodCutLayouts& operator=(const LodCutLayouts&) = delete;
  // Layouts built so far (one per hierarchy generation some cutter asked for or prepare()
  // was given).
  std::uint64_t builds() const;
  // Of those, the builds made into the memory of the layout before the latest (kept as a
  // spare, and reused once no cutter cuts on it any more).
  std::uint64_t reuses() const;
  // Builds the layout of `hierarchy`'s present generation unless it is built already, so the
  // first cut after an update finds it ready. At a million leaves a layout takes 0.1-0.4 s;
  // LodEpochHierarchy calls this on its worker after each update, where it costs a host's
  // serving thread nothing. Call it only while no cutter cuts on `hierarchy`.
  void prepare(const LodHierarchy& hierarchy);

 private:
  friend class LodCutter;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class LodCutter {
 public:
  // The selector's config supplies the view terms (margin, floor, near distance, bonus).
  explicit LodCutter(SelectorConfig config = {});
  LodCutter(LodCutter&&) noexcept;
  LodCutter& operator=(LodCutter&&) noexcept;
  ~LodCutter();

  // The cut of at most `budget` nodes for `pose`. `excluded` lists objects whose leaves are
  // kept elsewhere (any order, repeats allowed). Fails on an invalid pose or config.
  Expected<LodCut> cut(const LodHierarchy& hierarchy, const ClientPose& pose, std::size_t budget,
                       std::span<const ObjectId> excluded = {});
  // The same into `out`, reusing its vectors' memory.
  Status cut_into(LodCut& out, const LodHierarchy& hierarchy, const ClientPose& pose, std::size_t budget,
                  std::span<const ObjectId> excluded = {});
  // The same kept in the cutter, read with last() (a host's cut every pose update: no copy).
  // On the same hierarchy generation and exclusions as the last cut, the new cut is the last
  // one with the changes of the nodes whose refinement flipped merged in, not every refined
  // node opened again; both give the same cut. On failure last() is empty.
  Status cut_in_place(const LodHierarchy& hierarchy, const ClientPose& pose, std::size_t budget,
                      std::span<const ObjectId> excluded = {});
  const LodCut& last() const;

  // The hysteresis state: by default the nodes the previous cut refined.
  void clear_previous();
  // Takes the layouts from `layouts` (shared with other cutters) instead of building its own.
  void share_layouts(std::shared_ptr<LodCutLayouts> layouts);

 private:
  friend class LodCutLayouts;
  struct Layout;  // the tree in breadth-first order (lod_cut.cpp)
  struct Scratch;
  // cut_in_place's incremental path; false if the changes contradict the last cut (a bug),
  // which then is left for the full path to overwrite.
  bool merge_changes(std::size_t budget);
  SelectorConfig config_;
  std::shared_ptr<const Layout> layout_;       // null until the first cut
  std::shared_ptr<LodCutLayouts> layouts_;     // null: layout_ is this cutter's own
  std::unique_ptr<Scratch> scratch_;
  // The previous cut's refined nodes (pool index, id), taken from the hysteresis flags when
  // the layout is rebuilt and carried to the new one by id.
  std::vector<std::pair<std::uint32_t, std::uint64_t>> refined_prev_;
};

}  // namespace gauss
