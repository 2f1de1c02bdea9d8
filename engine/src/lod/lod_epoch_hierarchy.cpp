// LodEpochHierarchy: one hierarchy per scene epoch, shareable between sessions, updated on
// the caller's thread or a worker's (lod_epoch_hierarchy.h).
#include "gauss/engine/lod_epoch_hierarchy.h"

#include <algorithm>
#include <chrono>
#include <new>
#include <utility>

#include "gauss/engine/log_text.h"
#include "gauss/engine/system_memory.h"

namespace gauss {

namespace {

// Failures for want of memory start with this: their figures change from epoch to epoch, and
// they are said once all the same (drop()).
constexpr std::string_view kNoMemory = "not enough memory: ";

}  // namespace

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
  job_.scene = nullptr;  // this thread reads the scene
  Filter filter;
  filter.filtered = eligible != nullptr;
  filter.set = eligible;
  if (eligible && eligible->rule && !eligible->counts.surface_rule_applied) filter.own_rule = eligible->rule;
  if (Status st = prepare(scene, filter, job_, /*copy_span=*/false); !st) {
    // Nothing can run (a LodConfig the hierarchy refuses, too little memory): this epoch's
    // readers select leaves, and the reason is said once.
    epoch_ = scene.epoch();
    const Status said = drop(scene.epoch(), st.message());
    return settled ? said : settled;
  }
  run(job_);
  const Status now = finish(job_);
  return settled ? now : settled;
}

Expected<LodEpochHierarchy::Progress> LodEpochHierarchy::update_in_background(const SceneStore& scene,
                                                                              const EligibilityConfig* rule,
                                                                              bool read_on_worker) {
  std::unique_lock lock(mutex_);
  Status finished = Ok{};
  if (job_posted_) {
    if (!job_done_) return Progress::Working;
    finished = settle(lock);
  }
  if (Status st = checked(scene, nullptr); !st) return st.error();
  if (rule)
    if (Status st = validate(*rule); !st) return Error{"LoD: " + st.message()};
  // A failure taken up is said first; the next call starts the scene's epoch's update.
  if (!finished) return finished.error();
  if (epoch_ && *epoch_ == scene.epoch()) return Progress::Ready;
  Filter filter;
  filter.filtered = rule != nullptr;
  std::optional<EligibleSet> set;
  if (rule && surface_rule_may_apply(scene, *rule)) {
    // The surface rule reads the scene's surface: filter here, the worker gets the verdict.
    auto e = filter_eligible(scene, *rule);
    if (!e) return Error{"LoD: eligibility: " + e.message()};
    set = std::move(*e);
    filter.set = &*set;
    if (!set->counts.surface_rule_applied) filter.own_rule = *rule;
  } else if (rule) {
    filter.own_rule = *rule;
  }
  // read_on_worker: the worker copies the span or the changed Gaussians (copy_from_scene);
  // an eligible set computed here (the surface rule) is this call's, so its indices are
  // copied here all the same.
  job_.scene = read_on_worker ? &scene : nullptr;
  if (Status st = prepare(scene, filter, job_, /*copy_span=*/true); !st) {
    // Nothing can run (a LodConfig the hierarchy refuses, too little memory): the readers
    // must not wait for it, they select leaves for this epoch.
    job_.scene = nullptr;
    epoch_ = scene.epoch();
    if (Status said = drop(scene.epoch(), st.message()); !said) return said.error();
    return Progress::Ready;
  }
  job_posted_ = true;
  job_done_ = false;
  scene_read_ = job_.scene == nullptr;
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

bool LodEpochHierarchy::reading_scene() const {
  std::lock_guard lock(mutex_);
  return job_posted_ && !scene_read_;
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
      copy_from_scene(job_);
      lock.lock();
      scene_read_ = true;
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

Status LodEpochHierarchy::memory_for(std::size_t leaves_after, std::size_t copy_bytes, std::size_t held_copy_bytes) const {
  // A build needs what bytes_for() says of its leaves; an update, what the larger tree needs
  // beyond the present one (the estimate's own slack is already held), and a copy what it
  // needs beyond the last job's (whose buffer it reuses).
  const std::size_t leaves_now = hierarchy_ ? hierarchy_->leaf_count() : 0;
  const std::size_t total = LodHierarchy::bytes_for(leaves_after, sh_degree_) + copy_bytes;
  const std::size_t held = (hierarchy_ ? LodHierarchy::bytes_for(leaves_now, sh_degree_) : 0) + held_copy_bytes;
  const std::string what = "a hierarchy of " + std::to_string(leaves_after) + " Gaussians at SH degree " +
                           std::to_string(sh_degree_) + " needs about " + format_bytes(total);
  if (config_.max_bytes > 0) {
    if (total > config_.max_bytes)
      return Error{std::string(kNoMemory) + what + ", more than the " + format_bytes(config_.max_bytes) + " allowed"};
    return Ok{};
  }
  const std::size_t more = total > held ? total - held : 0;
  if (const auto headroom = memory_headroom(); headroom && more > headroom->bytes)
    return Error{std::string(kNoMemory) + what + (held > 0 ? " (" + format_bytes(more) + " more than it holds)" : "") +
                 ", and " + headroom->text()};
  return Ok{};
}

Status LodEpochHierarchy::prepare(const SceneStore& scene, const Filter& filter, Job& job, bool copy_span) {
  // The copies below and the hierarchy's pools can be large (a background update copies the
  // scene): too little memory is a failure like any other, the readers select leaves.
  try {
    return prepare_job(scene, filter, job, copy_span);
  } catch (const std::bad_alloc&) {
    job.gaussians = {};
    job.upserts = {};
    job.touched = {};
    job.subset = {};
    return Error{std::string(kNoMemory) + "copying " + std::to_string(scene.gaussians().size()) +
                 " Gaussians for the hierarchy's update ran out"};
  }
}

Status LodEpochHierarchy::prepare_job(const SceneStore& scene, const Filter& filter, Job& job, bool copy_span) {
  job.epoch = scene.epoch();
  job.result.reset();
  job.upserts.clear();
  job.removed.clear();
  job.subset.clear();
  job.subset_on_worker = false;
  job.from_change_log = false;
  job.filter = filter;
  job.filter.set = nullptr;
  const bool own = !filter.filtered || filter.own_rule.has_value();
  if (hierarchy_ && epoch_ && own && own_rule_known_ && own_rule_ == filter.own_rule) {
    // Each Gaussian's eligibility is its own, under the rule the leaves were chosen by: the
    // scene's change log says what changed, so apply it (work in the changes) instead of
    // comparing every Gaussian (work in N; 2.5x the cost at 1 %). A changed Gaussian that
    // fails the rule leaves (lenient: it may never have been a leaf).
    job.touched.clear();
    bool reaches = true;
    for (std::uint64_t e = to_underlying(*epoch_) + 1; e <= to_underlying(scene.epoch()) && reaches; ++e) {
      const EpochChanges* c = scene.changes(Epoch{e});
      if (!c) {
        reaches = false;  // the log no longer reaches back: compare everything
        break;
      }
      job.touched.insert(job.touched.end(), c->inserted.begin(), c->inserted.end());
      job.touched.insert(job.touched.end(), c->modified.begin(), c->modified.end());
      job.removed.insert(job.removed.end(), c->removed.begin(), c->removed.end());
    }
    if (reaches) {
      // At most every touched Gaussian becomes a leaf.
      if (Status st = memory_for(hierarchy_->leaf_count() + job.touched.size(), 0, 0); !st) return st;
      job.from_change_log = true;
      job.span = {};
      job.gaussians = {};  // a full job's copy is not kept for a scene that has a change log
      if (!job.scene) gather_changes(scene, job);
      return Ok{};
    }
    job.removed.clear();
    job.touched.clear();
  }
  const auto gaussians = scene.gaussians();
  // Checked before anything is copied or built: at most every Gaussian is a leaf.
  const std::size_t copy_bytes = copy_span ? gaussians.size() * (sizeof(Gaussian) + sizeof(std::uint32_t)) : 0;
  const std::size_t held_copy = job.gaussians.capacity() * sizeof(Gaussian) + job.subset.capacity() * sizeof(std::uint32_t);
  if (Status st = memory_for(gaussians.size(), copy_bytes, held_copy); !st) return st;
  // The whole span, not the eligible ones alone: the hierarchy remembers where each leaf was
  // in it (leaf_source), which the cut hands on as the leaf's place in the scene.
  if (copy_span) {
    if (gaussians.size() > job.gaussians.capacity()) {  // fresh room: on huge pages (system_memory.h)
      job.gaussians.clear();
      job.gaussians.reserve(gaussians.size());
      advise_huge_pages_for_room(job.gaussians);
    }
    if (job.scene) {
      job.span = {};  // copy_from_scene, on the worker
    } else {
      job.gaussians.assign(gaussians.begin(), gaussians.end());
      job.span = job.gaussians;
    }
  } else {
    job.span = gaussians;
  }
  if (filter.set) {
    job.subset.assign(filter.set->indices.begin(), filter.set->indices.end());
  } else if (copy_span && (filter.filtered || job.scene)) {
    job.subset_on_worker = true;  // over the copy: nothing more in N on the caller's thread
  } else {
    job.subset = own_subset(job.span, filter);
  }
  if (!hierarchy_) {
    auto h = LodHierarchy::create(sh_degree_, config_);
    if (!h) return Error{"LoD: " + h.message()};
    hierarchy_ = std::move(*h);
    ++lineage_;
  }
  return Ok{};
}

void LodEpochHierarchy::gather_changes(const SceneStore& scene, Job& job) {
  std::optional<EligibilityOwnRules> rules;
  if (job.filter.own_rule) rules.emplace(*job.filter.own_rule);
  std::sort(job.touched.begin(), job.touched.end());
  job.touched.erase(std::unique(job.touched.begin(), job.touched.end()), job.touched.end());
  job.upserts.reserve(job.touched.size());
  for (GaussianId id : job.touched) {
    const Gaussian* g = scene.find(id);
    if (!g) continue;  // inserted or modified, then removed: in `removed`
    if (g->carrier || (rules && !rules->passes(*g)))
      job.removed.push_back(id);  // turned carrier or ineligible: no longer a leaf
    else
      job.upserts.push_back(*g);
  }
  job.touched.clear();
  std::sort(job.removed.begin(), job.removed.end());
  job.removed.erase(std::unique(job.removed.begin(), job.removed.end()), job.removed.end());
}

void LodEpochHierarchy::copy_from_scene(Job& job) {
  if (!job.scene) return;
  const SceneStore& scene = *std::exchange(job.scene, nullptr);
  try {
    if (job.from_change_log) {
      gather_changes(scene, job);
    } else {
      job.gaussians.assign(scene.gaussians().begin(), scene.gaussians().end());
      job.span = job.gaussians;
    }
  } catch (const std::bad_alloc&) {
    // run() says so: an update from nothing fails like one that ran out.
    job.upserts = {};
    job.gaussians = {};
    job.span = {};
    job.copy_failed = true;
  }
}

std::vector<std::uint32_t> LodEpochHierarchy::own_subset(std::span<const Gaussian> gaussians, const Filter& filter) {
  std::optional<EligibilityOwnRules> rules;
  if (filter.own_rule) rules.emplace(*filter.own_rule);
  std::vector<std::uint32_t> subset;
  subset.reserve(gaussians.size());
  for (std::size_t i = 0; i < gaussians.size(); ++i)
    if (!gaussians[i].carrier && (!rules || rules->passes(gaussians[i]))) subset.push_back(static_cast<std::uint32_t>(i));
  return subset;
}

void LodEpochHierarchy::run(Job& job) {
  const auto start = std::chrono::steady_clock::now();
  job.built = hierarchy_->leaf_count() == 0;
  if (job.copy_failed) {
    job.copy_failed = false;
    hierarchy_.reset();
    job.result = Error{std::string(kNoMemory) + "copying the scene for the hierarchy's update ran out"};
    job.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return;
  }
  try {
    if (job.subset_on_worker) job.subset = own_subset(job.span, job.filter);
    // Removed ids that were never leaves (carriers, unusable ones) are fine: lenient.
    job.result = job.from_change_log ? hierarchy_->apply(job.upserts, job.removed, /*lenient_removes=*/true)
                                     : hierarchy_->update(job.span, job.subset);
  } catch (const std::bad_alloc&) {
    // Past the estimate (memory_for: a limit it cannot see, such as a container's). The
    // half-updated hierarchy goes first, giving its memory back (the job is this thread's
    // until it is taken up, and the readers wait for that), then the reason is written.
    const std::size_t given = job.from_change_log ? job.upserts.size() : job.span.size();
    hierarchy_.reset();
    job.result = Error{std::string(kNoMemory) + "the update ran out (" + std::to_string(given) + " Gaussians given)"};
  }
  job.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // The readers' cut layout of the new tree, here rather than in the first cut after it (on a
  // host's serving thread, 0.1-0.4 s at a million leaves). Only once some reader has cut: a
  // host whose clients' budgets hold every leaf never needs one.
  if (job.result->ok() && hierarchy_ && layouts_->builds() > 0) {
    try {
      layouts_->prepare(*hierarchy_);
    } catch (const std::bad_alloc&) {
      // The first cut builds it then, and says so if it cannot either.
    }
  }
}

Status LodEpochHierarchy::finish(Job& job) {
  epoch_ = job.epoch;
  Expected<LodUpdateReport>& report = *job.result;
  if (!report) {
    own_rule_known_ = false;
    return drop(job.epoch, report.message());
  }
  last_failure_.clear();
  own_rule_known_ = !job.filter.filtered || job.filter.own_rule.has_value();
  own_rule_ = job.filter.own_rule;
  change_log_updates_ += job.from_change_log;
  log_changes(*report);
  last_update_ = LodUpdateSummary{job.epoch, job.built, job.from_change_log, hierarchy_->leaf_count(),
                                  hierarchy_->interior_count(), job.seconds};
  return Ok{};
}

Status LodEpochHierarchy::drop(Epoch epoch, const std::string& why) {
  hierarchy_.reset();
  ++lineage_;
  // Said once per reason: a scene that keeps the cause (an id with the top bit, say) would
  // otherwise log a line every epoch. Want of memory is one reason whatever its figures.
  const std::string reason = std::string_view(why).starts_with(kNoMemory) ? std::string(kNoMemory) : why;
  if (reason == last_failure_) return Ok{};
  last_failure_ = reason;
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

std::uint64_t LodEpochHierarchy::change_log_updates() const {
  std::lock_guard lock(mutex_);
  return change_log_updates_;
}

std::uint64_t LodEpochHierarchy::updates() const {
  std::lock_guard lock(mutex_);
  return updates_;
}

std::optional<LodUpdateSummary> LodEpochHierarchy::last_update() const {
  std::lock_guard lock(mutex_);
  return last_update_;
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
