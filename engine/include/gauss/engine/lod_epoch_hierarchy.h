#pragma once
// LodEpochHierarchy: a LodHierarchy kept at a scene's epoch, which several host sessions may
// share. A merge hierarchy depends on the scene and the eligibility rule, not on a client: a
// host serving K clients with one hierarchy each held K copies (about 0.7 KB per Gaussian
// each) and did K times the same update per epoch. Sessions with the same eligibility rule and
// SH degree share one of these instead (SessionHost does); a LodSelector made alone owns one.
//
// update() brings it to the scene's epoch, once per epoch whichever session asks first:
// through the scene's change log when there is no eligibility filter (work in the changes),
// else by comparing every eligible Gaussian (work in N). It is thread-safe: sessions ticking
// in parallel call it at the top of their tick, the first does the work while the others wait,
// and the hierarchy is only read after that, until the scene's next epoch (which the host
// commits between ticks).
//
// What changed is kept as a short log of update reports (interior ids added, removed or
// modified), so each reader learns what it must re-quantise since it last looked
// (changes_since), even when it skipped epochs. A hierarchy that cannot be updated for an
// epoch is dropped (the readers select leaves) and built again from scratch at the next
// epoch; `lineage()` changes whenever that happens. The readers' cutters share one
// breadth-first copy of the tree per generation too (layouts()).
#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "gauss/engine/eligibility.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/lod_cut.h"
#include "gauss/engine/lod_hierarchy.h"
#include "gauss/engine/result.h"
#include "gauss/engine/scene_store.h"

namespace gauss {

class LodEpochHierarchy {
 public:
  LodEpochHierarchy(int sh_degree, LodConfig config = {});
  LodEpochHierarchy(const LodEpochHierarchy&) = delete;
  LodEpochHierarchy& operator=(const LodEpochHierarchy&) = delete;

  // Brings the hierarchy to the scene's eligible appearance Gaussians (`eligible` null: every
  // non-carrier), unless it already stands for the scene's epoch. Fails on an open epoch, on
  // an eligible set of another epoch, and when the hierarchy cannot be updated for a reason
  // not reported just before (a repeat returns Ok, so a shared failure is said once); the
  // hierarchy is then dropped until the next epoch.
  Status update(const SceneStore& scene, const EligibleSet* eligible);

  // The hierarchy, or null when none is held (never built, or dropped). Read between updates.
  const LodHierarchy* hierarchy() const { return hierarchy_ ? &*hierarchy_ : nullptr; }
  // The epoch the last update() stood for (whether or not it succeeded).
  std::optional<Epoch> epoch() const { return epoch_; }
  // Successful updates so far; a reader remembers this to ask changes_since() next time.
  std::uint64_t updates() const;
  // Appends the interior ids that updates after the first `seen` added, removed or modified
  // to `out`. False (appending nothing) when the log no longer reaches back that far: the
  // reader must then treat every interior record it holds as changed.
  bool changes_since(std::uint64_t seen, std::vector<GaussianId>& out) const;
  // Changes whenever the hierarchy is built from scratch or dropped: a reader's caches of
  // node indices (a previous cut) are then meaningless.
  std::uint64_t lineage() const { return lineage_; }
  // The cutters' breadth-first copies of this hierarchy, one per generation for all readers.
  const std::shared_ptr<LodCutLayouts>& layouts() const { return layouts_; }

  // Update reports the log keeps (each a few ids per changed cell).
  static constexpr std::size_t kLogLength = 32;

 private:
  // The scene's change log since epoch_ applied; nullopt when the log no longer reaches back.
  std::optional<Status> apply_change_log(const SceneStore& scene);
  Status drop(const SceneStore& scene, const std::string& why);
  void log_changes(const LodUpdateReport& report);

  int sh_degree_;
  LodConfig config_;
  mutable std::mutex mutex_;  // update() against update() and the log's readers
  std::optional<LodHierarchy> hierarchy_;
  std::optional<Epoch> epoch_;
  std::string last_failure_;  // why the last update failed (empty after a success)
  std::uint64_t lineage_{0};
  std::uint64_t updates_{0};
  std::deque<std::vector<GaussianId>> log_;  // the last kLogLength updates' ids, oldest first
  std::vector<std::uint32_t> subset_;        // scratch
  std::shared_ptr<LodCutLayouts> layouts_ = std::make_shared<LodCutLayouts>();
};

}  // namespace gauss
