#pragma once
// LodSelector: a host session's selection with a coarse background. It reads a LodHierarchy
// over the scene's eligible appearance Gaussians (updated once per epoch, incrementally; its
// own, or one shared with the host's other sessions: lod_epoch_hierarchy.h) and turns the leaf selector's choice into: the semantic reservation's leaves, exactly as the
// Selector chose them (min(|G_obj|, floor(rho M)) of the query's target, counted in leaves),
// plus a cut of at most M - M_obj nodes through the rest of the hierarchy (lod_cut.h) instead
// of M - M_obj background leaves. So what the budget cannot hold in detail is still on the
// client, coarse, instead of a hole.
//
// When the background's leaves fit in their share (M >= N, or a small scene) the Selector's
// own selection is returned unchanged: LoD changes nothing where nothing needs dropping.
//
// Interior nodes are ordinary records under ids with kLodInteriorIdBit set (sorted after
// every leaf); their values live in the hierarchy's record pool, which a selection's
// indices name above the scene's size (Differ::diff's `extra`). Leaves the hierarchy left out
// as unusable (non-finite, zero weight, enormous; lod_merge.h) are not in a cut.
//
// A hierarchy that cannot be updated for an epoch (an id with the top bit set, say) leaves the
// selector without one: select() then returns the leaf selection, and update() says why, once
// per reason and hierarchy (the next epochs try again from scratch, quietly while the reason
// is the same).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "gauss/engine/codec.h"
#include "gauss/engine/eligibility.h"
#include "gauss/engine/gaussian.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/lod_cut.h"
#include "gauss/engine/lod_epoch_hierarchy.h"
#include "gauss/engine/lod_hierarchy.h"
#include "gauss/engine/result.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/selector.h"

namespace gauss {

class LodSelector {
 public:
  // With its own hierarchy.
  LodSelector(int sh_degree, SelectorConfig selector = {}, LodConfig lod = {});
  // Reading `shared` (not null), which other selectors may read too: they must all pass the
  // same eligibility filter to update().
  LodSelector(std::shared_ptr<LodEpochHierarchy> shared, SelectorConfig selector = {});

  // Brings the hierarchy to the scene's eligible appearance Gaussians (`eligible` null: every
  // non-carrier) unless it stands for the scene's epoch already (LodEpochHierarchy::update),
  // and learns which interior records changed since this selector last looked. Fails when
  // the hierarchy cannot be updated for a reason not reported just before (a repeat returns
  // Ok); the selector then holds none, select() returns leaf selections, and the next epoch
  // builds it again from scratch.
  Status update(const SceneStore& scene, const EligibleSet* eligible);
  // update()'s reader side alone, for a hierarchy that another caller updates in the
  // background (LodEpochHierarchy::update_in_background): true when it stands for the scene's
  // epoch (what changed since this selector last looked is then learnt, and select() may run),
  // false while an update is still at work (select nothing yet).
  bool follow(const SceneStore& scene);

  // A host session's whole selection: `selector`'s reservation, and a cut where the
  // background's leaves do not all fit. The Selector then never ranks the background
  // (SelectionRequest::background_leaves false; the cut replaces it), which was most of a pose
  // update's cost at a million Gaussians; where the background fits (or no hierarchy is held)
  // it is the Selector's own leaf selection, as select() below gives it. `eligible`: the
  // session's eligibility filter's verdict, or null.
  Expected<Selection> select(Selector& selector, const SceneStore& scene, const EligibleSet* eligible,
                             const ClientPose& pose, const SelectionRequest& request);
  // The leaf selection `leaves` (from a Selector, for the same scene, pose and request, with
  // the background's leaves unless a cut replaces them) with its background replaced by a
  // cut when the background's leaves do not all fit.
  Expected<Selection> select(Selection leaves, const SceneStore& scene, const ClientPose& pose,
                             const SelectionRequest& request);

  // The records a selection's indices above the scene's size name (Differ::diff's `extra`).
  std::span<const Gaussian> records() const;
  // Interior ids whose records changed (or that were retired) in updates since the last
  // clear_modified(): what the differ must re-quantise beside the scene's change log.
  std::span<const GaussianId> modified() const { return modified_; }
  void clear_modified() { modified_.clear(); }
  // The current record of interior node `id`, or null when the hierarchy has no such node.
  // Waits for a background update still running.
  const Gaussian* find_interior(GaussianId id) const;
  // The hierarchy, when one is held.
  const LodHierarchy* hierarchy() const { return source_->hierarchy(); }
  // The last cut's figures (zero when the last selection needed none).
  const LodCut& last_cut() const;

 private:
  // After an update: the interior ids changed since this selector last looked, into modified_.
  void learn_changes();

  std::shared_ptr<LodEpochHierarchy> source_;
  std::optional<std::uint64_t> seen_updates_;  // source_->updates() when last looked
  std::uint64_t seen_lineage_{0};
  LodCutter cutter_;
  bool cut_used_{false};  // the last selection holds cutter_.last()
  std::vector<GaussianId> modified_;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> chosen_;    // select()'s reservation leaves (scratch)
};

// `params` with its log-scale range widened so that no record of a hierarchy over Gaussians
// inside params.box is clamped: a parent is wider than its children, and a cut sends parents.
// A record's covariance is within + spread^2 (centres' spread); the first is at most the widest
// leaf's (exp(2 log_scale_max)), the second at most the squared half-diagonal of the box (every
// centre lies in it), so sqrt(e^(2 max) + spread^2 h^2) bounds every scale. A bound of the box
// and range alone, not of the scene: a host and an evaluation fitting the same box agree
// whatever epochs each has seen, and nothing is built to fit it. The other ranges need
// nothing: a parent's mean and colours are weighted means of its leaves'.
CodecParams fit_lod_codec_params(CodecParams params, const LodMergeConfig& merge = {});

}  // namespace gauss
