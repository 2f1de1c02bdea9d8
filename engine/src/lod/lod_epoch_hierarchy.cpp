// LodEpochHierarchy: one hierarchy per scene epoch, shareable between sessions, updated on
// the caller's thread or a worker's (lod_epoch_hierarchy.h).
#include "gauss/engine/lod_epoch_hierarchy.h"

#include <algorithm>
#include <utility>

namespace gauss {

LodEpochHierarchy::LodEpochHierarchy(int sh_degree, LodConfig config) : sh_degree_(sh_degree), config_(config) {}

LodEpochHierarchy::~LodEpochHierarchy() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  job_cv_.notify_all();
  if (worker_.joinable()) worker_.join();  // a running update finishes first
}

Status LodEpochHierarchy::checked(const SceneStore& scene, const EligibleSet* eligible) const {
  if (scene.in_epoch()) return Error{"LoD: the scene has an open epoch; update between epochs"};
  if (eligible && eligible->epoch != scene.epoch())
    return Error{"LoD: eligible set is from epoch " + std::to_string(to_underlying(eligible->epoch)) +
                 ", the scene is at epoch " + std::to_string(to_underlying(scene.epoch()))};
  return Ok{};
}

Status LodEpochHierarchy::update(const SceneStore& scene, const EligibleSet* eligible) {
  std::unique_lock lock(mutex_);
  const Status settled = settle(lock);
  if (Status st = checked(scene, eligible); !st) return st;
  // Once per epoch: a failed update is not retried (and reported again) every tick, and the
  // sessions sharing this one find it done.
  if (epoch_ && *epoch_ == scene.epoch()) return settled;
  if (Status st = prepare(scene, eligible, job_, /*copy_span=*/false); !st) return st;
  run(job_);
  const Status now = finish(job_);
  return settled ? now : settled;
}

Expected<LodEpochHierarchy::Progress> LodEpochHierarchy::update_in_background(const SceneStore& scene,
                                                                              const EligibleSet* eligible) {
  std::unique_lock lock(mutex_);
  Status finished = Ok{};
  if (job_posted_) {
    if (!job_done_) return Progress::Working;
    finished = settle(lock);
  }
  if (Status st = checked(scene, eligible); !st) return st.error();
  // A failure taken up is said first; the next call starts the scene's epoch's update.
  if (!finished) return finished.error();
  if (epoch_ && *epoch_ == scene.epoch()) return Progress::Ready;
  if (Status st = prepare(scene, eligible, job_, /*copy_span=*/true); !st) {
    // Nothing can run (a LodConfig the hierarchy refuses): the readers must not wait for it,
    // they select leaves for this epoch.
    epoch_ = scene.epoch();
    if (Status said = drop(scene.epoch(), st.message()); !said) return said.error();
    return Progress::Ready;
  }
  job_posted_ = true;
  job_done_ = false;
  if (!worker_.joinable()) worker_ = std::thread([this] { worker_loop(); });
  lock.unlock();
  job_cv_.notify_one();
  return Progress::Working;
}

LodEpochHierarchy::Progress LodEpochHierarchy::progress(const SceneStore& scene) const {
  std::lock_guard lock(mutex_);
  return !job_posted_ && epoch_ && *epoch_ == scene.epoch() ? Progress::Ready : Progress::Working;
}

bool LodEpochHierarchy::busy() const {
  std::lock_guard lock(mutex_);
  return job_posted_;
}

void LodEpochHierarchy::wait_idle() const {
  std::unique_lock lock(mutex_);
  done_cv_.wait(lock, [this] { return !job_posted_ || job_done_; });
}

Status LodEpochHierarchy::settle(std::unique_lock<std::mutex>& lock) {
  if (!job_posted_) return Ok{};
  done_cv_.wait(lock, [this] { return job_done_; });
  job_posted_ = false;
  job_done_ = false;
  return finish(job_);
}

void LodEpochHierarchy::worker_loop() {
  std::unique_lock lock(mutex_);
  for (;;) {
    job_cv_.wait(lock, [this] { return stopping_ || (job_posted_ && !job_done_); });
    if (job_posted_ && !job_done_) {
      // The job and the hierarchy are the worker's until job_done_: every reader waits for
      // Ready, which no call returns while a job is posted.
      lock.unlock();
      run(job_);
      lock.lock();
      job_done_ = true;
      done_cv_.notify_all();
      continue;
    }
    if (stopping_) return;
  }
}

Status LodEpochHierarchy::prepare(const SceneStore& scene, const EligibleSet* eligible, Job& job,
                                  bool copy_span) {
  job.epoch = scene.epoch();
  job.result.reset();
  job.upserts.clear();
  job.removed.clear();
  job.subset.clear();
  job.from_change_log = false;
  if (hierarchy_ && !eligible && epoch_) {
    // Without an eligibility filter the scene's change log says what changed: apply it (work
    // in the changes) instead of comparing every Gaussian (work in N; 2.5x the cost at 1 %).
    std::vector<GaussianId> touched;
    bool reaches = true;
    for (std::uint64_t e = to_underlying(*epoch_) + 1; e <= to_underlying(scene.epoch()) && reaches; ++e) {
      const EpochChanges* c = scene.changes(Epoch{e});
      if (!c) {
        reaches = false;  // the log no longer reaches back: compare everything
        break;
      }
      touched.insert(touched.end(), c->inserted.begin(), c->inserted.end());
      touched.insert(touched.end(), c->modified.begin(), c->modified.end());
      job.removed.insert(job.removed.end(), c->removed.begin(), c->removed.end());
    }
    if (reaches) {
      std::sort(touched.begin(), touched.end());
      touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
      job.upserts.reserve(touched.size());
      for (GaussianId id : touched) {
        const Gaussian* g = scene.find(id);
        if (!g) continue;  // inserted or modified, then removed: in `removed`
        if (g->carrier)
          job.removed.push_back(id);  // turned carrier: no longer an appearance leaf
        else
          job.upserts.push_back(*g);
      }
      std::sort(job.removed.begin(), job.removed.end());
      job.removed.erase(std::unique(job.removed.begin(), job.removed.end()), job.removed.end());
      job.from_change_log = true;
      job.span = {};
      job.gaussians = {};  // a full job's copy is not kept for a scene that has a change log
      return Ok{};
    }
    job.removed.clear();
  }
  const auto gaussians = scene.gaussians();
  // The whole span, not the eligible ones alone: the hierarchy remembers where each leaf was
  // in it (leaf_source), which the cut hands on as the leaf's place in the scene.
  if (copy_span) {
    job.gaussians.assign(gaussians.begin(), gaussians.end());
    job.span = job.gaussians;
  } else {
    job.span = gaussians;
  }
  if (eligible) {
    job.subset.assign(eligible->indices.begin(), eligible->indices.end());
  } else {
    for (std::size_t i = 0; i < gaussians.size(); ++i)
      if (!gaussians[i].carrier) job.subset.push_back(static_cast<std::uint32_t>(i));
  }
  if (!hierarchy_) {
    auto h = LodHierarchy::create(sh_degree_, config_);
    if (!h) return Error{"LoD: " + h.message()};
    hierarchy_ = std::move(*h);
    ++lineage_;
  }
  return Ok{};
}

void LodEpochHierarchy::run(Job& job) {
  // Removed ids that were never leaves (carriers, unusable ones) are fine: lenient.
  job.result = job.from_change_log ? hierarchy_->apply(job.upserts, job.removed, /*lenient_removes=*/true)
                                   : hierarchy_->update(job.span, job.subset);
}

Status LodEpochHierarchy::finish(Job& job) {
  epoch_ = job.epoch;
  Expected<LodUpdateReport>& report = *job.result;
  if (!report) return drop(job.epoch, report.message());
  last_failure_.clear();
  log_changes(*report);
  return Ok{};
}

Status LodEpochHierarchy::drop(Epoch epoch, const std::string& why) {
  hierarchy_.reset();
  ++lineage_;
  // Said once per reason: a scene that keeps the cause (an id with the top bit, say) would
  // otherwise log a line every epoch.
  if (why == last_failure_) return Ok{};
  last_failure_ = why;
  return Error{"LoD: no hierarchy for epoch " + std::to_string(to_underlying(epoch)) + ": " + why +
               "; selecting leaves until it can be built"};
}

void LodEpochHierarchy::log_changes(const LodUpdateReport& report) {
  // Modified records are re-quantised by a reader's differ; retired ones leave its next cut
  // (the differ removes them as leavers), listed too so a stale pool slot is never trusted;
  // added ones too: a hierarchy built again after a drop counts its serials from 0, so a new
  // node may carry an id a client held before.
  std::vector<GaussianId> ids;
  ids.reserve(report.modified.size() + report.removed.size() + report.added.size());
  ids.insert(ids.end(), report.modified.begin(), report.modified.end());
  ids.insert(ids.end(), report.removed.begin(), report.removed.end());
  ids.insert(ids.end(), report.added.begin(), report.added.end());
  if (log_.size() == kLogLength) log_.pop_front();
  log_.push_back(std::move(ids));
  ++updates_;
}

std::uint64_t LodEpochHierarchy::updates() const {
  std::lock_guard lock(mutex_);
  return updates_;
}

bool LodEpochHierarchy::changes_since(std::uint64_t seen, std::vector<GaussianId>& out) const {
  std::lock_guard lock(mutex_);
  if (seen >= updates_) return true;
  const std::uint64_t missing = updates_ - seen;
  if (missing > log_.size()) return false;
  for (std::size_t k = log_.size() - std::size_t(missing); k < log_.size(); ++k)
    out.insert(out.end(), log_[k].begin(), log_[k].end());
  return true;
}

}  // namespace gauss
