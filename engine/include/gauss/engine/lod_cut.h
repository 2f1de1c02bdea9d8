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
// behind it may still refine. Ties go to the lower id, so a cut is a function of the
// hierarchy, the pose, B and the previous cut.
//
// Hysteresis (SelectorConfig::retention_bonus): a node refined in the previous cut has its
// error multiplied by 1 + bonus, so a small pose change does not coarsen and refine the same
// nodes back and forth. set_previous / clear_previous override or forget it, as the
// selector's set_resident does.
//
// Excluded objects (a query's targets, whose leaves the semantic reservation keeps at full
// detail): a node whose leaves all belong to them is left out of the cut; a node that mixes
// them with other leaves is always refined, or it would show the target a second time,
// coarse. The hierarchy gives each object its own subtree, so only the nodes on the paths
// from the root to the targets' subtrees mix; refining them is forced, and when that alone
// leaves more than B nodes the cut keeps the B with the largest error.
//
// Cost: O(K log K) for a cut of K nodes (a binary heap over the frontier), independent of
// the scene's size; no allocation per call once warm.
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "gauss/engine/ids.h"
#include "gauss/engine/lod_hierarchy.h"
#include "gauss/engine/result.h"
#include "gauss/engine/selector.h"

namespace gauss {

struct LodCut {
  std::vector<std::uint32_t> nodes;  // pool indices of the cut's nodes, in no particular order
  std::size_t leaves{0};             // how many of them are leaves
  std::size_t interior{0};           // and interior nodes
  std::size_t refined{0};            // nodes replaced by their children (the work)
  std::size_t retained{0};           // refined nodes that were refined in the previous cut
};

class LodCutter {
 public:
  // The selector's config supplies the view terms (margin, floor, near distance, bonus).
  explicit LodCutter(SelectorConfig config = {});

  // The cut of at most `budget` nodes for `pose`. `excluded` lists objects whose leaves are
  // kept elsewhere (any order, repeats allowed). Fails on an invalid pose or config.
  Expected<LodCut> cut(const LodHierarchy& hierarchy, const ClientPose& pose, std::size_t budget,
                       std::span<const ObjectId> excluded = {});

  // The hysteresis state: by default the nodes the previous cut refined.
  void clear_previous();

 private:
  struct Frontier {
    float key;
    std::uint64_t id;
    std::uint32_t node;
  };
  SelectorConfig config_;
  // Per pool index: the id of the node that was refined there in the previous cut (interior
  // ids are never 0), so a pool entry reused by a later update never inherits the bonus.
  std::vector<std::uint64_t> refined_id_;
  std::vector<std::uint32_t> refined_list_;
  std::vector<std::uint32_t> refined_next_;
  // Per pool index: 1 = all leaves excluded, 2 = mixes excluded and other leaves; stamped.
  std::vector<std::uint32_t> mark_stamp_;
  std::vector<std::uint8_t> mark_;
  std::uint32_t stamp_{0};
  std::vector<Frontier> heap_;
};

}  // namespace gauss
