#pragma once
// LodEpochHierarchy: a LodHierarchy kept at a scene's epoch, which several host sessions may
// share. A merge hierarchy depends on the scene and the eligibility rule, not on a client: a
// host serving K clients with one hierarchy each held K copies (about 0.7 KB per Gaussian
// each) and did K times the same update per epoch. Sessions with the same eligibility rule and
// SH degree share one of these instead (SessionHost does); a LodSelector made alone owns one.
//
// update() brings it to the scene's epoch, once per epoch whichever session asks first:
// through the scene's change log when each Gaussian's eligibility depends on it alone (no
// filter, or one whose surface rule does not apply) and the rule is the last update's (work
// in the changes), else by comparing every eligible Gaussian (work in N). It is thread-safe:
// sessions ticking in parallel call it at the top of their tick, the first does the work while
// the others wait, and the hierarchy is only read after that, until the scene's next epoch
// (which the host commits between ticks).
//
// What changed is kept as a short log of update reports (interior ids added, removed or
// modified), so each reader learns what it must re-quantise since it last looked
// (changes_since), even when it skipped epochs. A hierarchy that cannot be updated for an
// epoch is dropped (the readers select leaves) and built again from scratch at the next
// epoch; `lineage()` changes whenever that happens. The readers' cutters share one
// breadth-first copy of the tree per generation too (layouts()), which each update builds
// once some reader has cut (on the worker, for an update in the background), so no reader's
// first cut after an update waits for it.
//
// In the background. update() does the work on the caller's thread: at a million Gaussians
// that is 50-120 ms per 1 % epoch and about a second for the first build, during which a host's
// serving thread answered nobody. update_in_background() hands it to a worker thread instead:
// the caller copies what the update reads out of the scene (the changed Gaussians on the
// change-log path, the whole span on the others, which the worker then filters itself unless
// the surface rule applies), so the scene may change while the worker runs, and gets Working
// back until the hierarchy stands for the scene's epoch. Its readers
// ask progress() and read nothing of the hierarchy while it says Working; the next
// update_in_background() takes the finished work up and, when the scene moved on meanwhile,
// starts the next.
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "gauss/engine/eligibility.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/lod_cut.h"
#include "gauss/engine/lod_hierarchy.h"
#include "gauss/engine/result.h"
#include "gauss/engine/scene_store.h"

namespace gauss {

// What an update did and how long it took, for a host's log: a 1M-Gaussian build takes about
// a second, during which the LoD clients receive nothing.
struct LodUpdateSummary {
  Epoch epoch{0};
  bool built{false};            // the hierarchy had no leaf before: a full build
  bool from_change_log{false};  // else it compared every eligible Gaussian
  std::size_t leaves{0};        // after the update
  std::size_t interior{0};
  double seconds{0.0};          // the update itself, on the thread that ran it
};

class LodEpochHierarchy {
 public:
  LodEpochHierarchy(int sh_degree, LodConfig config = {});
  LodEpochHierarchy(const LodEpochHierarchy&) = delete;
  LodEpochHierarchy& operator=(const LodEpochHierarchy&) = delete;
  // Waits for a background update still running.
  ~LodEpochHierarchy();

  // Brings the hierarchy to the scene's eligible appearance Gaussians (`eligible` null: every
  // non-carrier), unless it already stands for the scene's epoch. Fails on an open epoch, on
  // an eligible set of another epoch, and when the hierarchy cannot be updated for a reason
  // not reported just before (a repeat returns Ok, so a shared failure is said once); the
  // hierarchy is then dropped until the next epoch.
  // Waits for a background update first (and takes it up).
  Status update(const SceneStore& scene, const EligibleSet* eligible);

  enum class Progress { Ready, Working };
  // update() on a worker thread, for one caller (a host's loop, between its sessions' ticks).
  // Ready: the hierarchy stands for the scene's epoch (or was dropped for it: hierarchy() null)
  // and may be read until the scene's next epoch. Working: an update runs (started now or
  // before); read nothing of the hierarchy. A failure is reported as update() reports it,
  // once per reason; the next call then starts the update for the scene's epoch. `rule`: the
  // eligibility filter (null: every non-carrier), which this applies itself, and only where
  // it must (the changed Gaussians, when the change log serves).
  // `read_on_worker`: the worker copies what it needs from the scene itself, so the caller's
  // thread does not (a first build's copy of a million Gaussians was 70-550 ms of it, a
  // snapshot moving every one 60-150 ms); the caller must then change the scene by nothing
  // until reading_scene() is false. Else the caller's thread copies it before returning.
  Expected<Progress> update_in_background(const SceneStore& scene, const EligibilityConfig* rule,
                                          bool read_on_worker = false);
  // A background update still reads the scene it was started for (read_on_worker).
  bool reading_scene() const;
  // Updates so far that followed the scene's change log (the others compared every Gaussian).
  std::uint64_t change_log_updates() const;
  // What update_in_background() would say of the scene now, without starting or taking up
  // anything: for the readers (the sessions' ticks, in parallel).
  Progress progress(const SceneStore& scene) const;
  // Whether background work is outstanding: running, or finished and not yet taken up. A host
  // that commits epochs faster than updates finish would otherwise never serve one: it waits
  // for this to clear before committing the next (gauss-host does).
  bool busy() const;
  // Blocks until no background update runs (the next update call takes its result up). For a
  // reader outside the ticks that must read the hierarchy now (a test, LodSelector::find_interior).
  void wait_idle() const;

  // The hierarchy, or null when none is held (never built, or dropped). Read between updates.
  const LodHierarchy* hierarchy() const { return hierarchy_ ? &*hierarchy_ : nullptr; }
  // The epoch the last update() stood for (whether or not it succeeded).
  std::optional<Epoch> epoch() const { return epoch_; }
  // Successful updates so far; a reader remembers this to ask changes_since() next time.
  std::uint64_t updates() const;
  // The last successful update's summary (none before the first).
  std::optional<LodUpdateSummary> last_update() const;
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
  // One update's inputs, copied out of the scene so that it may change meanwhile, and its result.
  // What chooses the leaves: no filter, a rule, and/or the eligible set already computed.
  struct Filter {
    bool filtered{false};
    std::optional<EligibilityConfig> own_rule;  // when filtered and each verdict is a Gaussian's own
    const EligibleSet* set{nullptr};            // the verdict, when the caller has it
  };
  struct Job {
    Epoch epoch{0};
    bool from_change_log{false};
    Filter filter;                     // set is null on the worker's job (the caller's set may go)
    std::vector<Gaussian> upserts;     // change log: inserted or modified appearance Gaussians
    std::vector<GaussianId> removed;   // change log: removed, or turned carrier
    std::span<const Gaussian> span;    // otherwise: the scene's whole span (places matter),
    std::vector<Gaussian> gaussians;   //   copied here for the worker (the span then views it),
    std::vector<std::uint32_t> subset; //   and the indices of the eligible ones in it
    bool subset_on_worker{false};      //   (computed by run() from filter.own_rule)
    // read_on_worker: the scene the worker copies from (the span, or the changes below)
    // before it updates; null once copied, or when the caller's thread copied.
    const SceneStore* scene{nullptr};
    std::vector<GaussianId> touched;   // change log: inserted or modified, unsorted, repeats
    bool copy_failed{false};           // copy_from_scene ran out of memory
    std::optional<Expected<LodUpdateReport>> result;
    bool built{false};                 // run(): the hierarchy had no leaf before
    double seconds{0.0};               // run(): how long the update took
  };
  // Fills `job` for the scene's epoch: from the change log when it reaches back to epoch_ and
  // the filter is the last update's own rule (or none), else the whole span (a copy when
  // `copy_span`: the worker's job outlives the scene's epoch; the caller's thread reads the
  // scene itself). Creates the hierarchy when none is held.
  // Fails, copying nothing, when the update would need more memory than there is (below).
  Status prepare(const SceneStore& scene, const Filter& filter, Job& job, bool copy_span);
  Status prepare_job(const SceneStore& scene, const Filter& filter, Job& job, bool copy_span);
  // Whether a hierarchy of `leaves_after` leaves and `copy_bytes` of the job's copies fit in
  // LodConfig::max_bytes, or else in what the process can still have (memory_headroom()) beyond what this holds
  // (the hierarchy, and `held_copy_bytes` of the last job's copies, whose buffers are reused).
  Status memory_for(std::size_t leaves_after, std::size_t copy_bytes, std::size_t held_copy_bytes) const;
  // The indices of the non-carriers that pass the filter's own rule (every one without it).
  static std::vector<std::uint32_t> own_subset(std::span<const Gaussian> gaussians, const Filter& filter);
  // Reads the change log's Gaussians into job.upserts (touched -> upserts, failing the rule
  // or turned carrier -> removed): on the caller's thread, or the worker's (read_on_worker).
  static void gather_changes(const SceneStore& scene, Job& job);
  // Copies what a read_on_worker job needs from its scene; then the scene is released.
  void copy_from_scene(Job& job);
  // Runs a prepared job on the hierarchy (the caller's thread or the worker).
  void run(Job& job);
  // Takes a finished job's result up: the epoch, the log, or a drop. Under mutex_.
  Status finish(Job& job);
  Status checked(const SceneStore& scene, const EligibleSet* eligible) const;
  Status drop(Epoch epoch, const std::string& why);
  void log_changes(const LodUpdateReport& report);
  // Waits (under `lock` on mutex_) for a running job and takes it up; returns its status.
  Status settle(std::unique_lock<std::mutex>& lock);
  void worker_loop();

  int sh_degree_;
  LodConfig config_;
  mutable std::mutex mutex_;  // update() against update() and the log's readers
  std::optional<LodHierarchy> hierarchy_;
  std::optional<Epoch> epoch_;
  std::string last_failure_;  // why the last update failed (empty after a success)
  // The rule the leaves were chosen by, when each verdict was a Gaussian's own (own_rule_
  // empty: no filter); the change log can only carry the hierarchy forward under the same.
  bool own_rule_known_{false};
  std::optional<EligibilityConfig> own_rule_;
  std::uint64_t change_log_updates_{0};
  std::uint64_t lineage_{0};
  std::uint64_t updates_{0};
  std::optional<LodUpdateSummary> last_update_;
  std::deque<std::vector<GaussianId>> log_;  // the last kLogLength updates' ids, oldest first
  std::shared_ptr<LodCutLayouts> layouts_ = std::make_shared<LodCutLayouts>();

  // The background update: one job at a time, run by worker_ (started at the first).
  Job job_;
  bool job_posted_{false};  // job_ handed to the worker and not yet taken up
  bool job_done_{false};    // the worker finished job_ (its result is in job_.result)
  bool scene_read_{true};   // the posted job no longer reads the scene (read_on_worker)
  bool stopping_{false};
  mutable std::condition_variable job_cv_;   // worker: a job is posted or stopping
  mutable std::condition_variable done_cv_;  // waiters: the job is done
  std::thread worker_;
};

}  // namespace gauss
