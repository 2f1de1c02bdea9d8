// LodEpochHierarchy: one hierarchy per scene epoch, shareable between sessions
// (lod_epoch_hierarchy.h).
#include "gauss/engine/lod_epoch_hierarchy.h"

#include <algorithm>
#include <utility>

namespace gauss {

LodEpochHierarchy::LodEpochHierarchy(int sh_degree, LodConfig config) : sh_degree_(sh_degree), config_(config) {}

Status LodEpochHierarchy::update(const SceneStore& scene, const EligibleSet* eligible) {
  std::lock_guard lock(mutex_);
  if (scene.in_epoch()) return Error{"LoD: the scene has an open epoch; update between epochs"};
  // Once per epoch: a failed update is not retried (and reported again) every tick, and the
  // sessions sharing this one find it done.
  if (epoch_ && *epoch_ == scene.epoch()) return Ok{};
  if (eligible && eligible->epoch != scene.epoch())
    return Error{"LoD: eligible set is from epoch " + std::to_string(to_underlying(eligible->epoch)) +
                 ", the scene is at epoch " + std::to_string(to_underlying(scene.epoch()))};
  const auto gaussians = scene.gaussians();
  if (hierarchy_ && !eligible && epoch_) {
    // Without an eligibility filter the scene's change log says what changed: apply it (work
    // in the changes) instead of comparing every Gaussian (work in N; 2.5x the cost at 1 %).
    if (auto applied = apply_change_log(scene)) {
      epoch_ = scene.epoch();
      return *applied ? Status(Ok{}) : drop(scene, applied->message());
    }
  }
  subset_.clear();
  if (eligible) {
    subset_.assign(eligible->indices.begin(), eligible->indices.end());
  } else {
    for (std::size_t i = 0; i < gaussians.size(); ++i)
      if (!gaussians[i].carrier) subset_.push_back(static_cast<std::uint32_t>(i));
  }
  if (!hierarchy_) {
    auto h = LodHierarchy::create(sh_degree_, config_);
    if (!h) return Error{"LoD: " + h.message()};
    hierarchy_ = std::move(*h);
    ++lineage_;
  }
  auto report = hierarchy_->update(gaussians, subset_);
  epoch_ = scene.epoch();
  if (!report) return drop(scene, report.message());
  last_failure_.clear();
  log_changes(*report);
  return Ok{};
}

Status LodEpochHierarchy::drop(const SceneStore& scene, const std::string& why) {
  hierarchy_.reset();
  ++lineage_;
  // Said once per reason: a scene that keeps the cause (an id with the top bit, say) would
  // otherwise log a line every epoch.
  if (why == last_failure_) return Ok{};
  last_failure_ = why;
  return Error{"LoD: no hierarchy for epoch " + std::to_string(to_underlying(scene.epoch())) + ": " + why +
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

std::optional<Status> LodEpochHierarchy::apply_change_log(const SceneStore& scene) {
  std::vector<GaussianId> touched, removed;
  for (std::uint64_t e = to_underlying(*epoch_) + 1; e <= to_underlying(scene.epoch()); ++e) {
    const EpochChanges* c = scene.changes(Epoch{e});
    if (!c) return std::nullopt;  // the log no longer reaches back: compare everything
    touched.insert(touched.end(), c->inserted.begin(), c->inserted.end());
    touched.insert(touched.end(), c->modified.begin(), c->modified.end());
    removed.insert(removed.end(), c->removed.begin(), c->removed.end());
  }
  std::sort(touched.begin(), touched.end());
  touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
  std::vector<Gaussian> upserts;
  upserts.reserve(touched.size());
  for (GaussianId id : touched) {
    const Gaussian* g = scene.find(id);
    if (!g) continue;  // inserted or modified, then removed: in `removed`
    if (g->carrier)
      removed.push_back(id);  // turned carrier: no longer an appearance leaf
    else
      upserts.push_back(*g);
  }
  std::sort(removed.begin(), removed.end());
  removed.erase(std::unique(removed.begin(), removed.end()), removed.end());
  // Removed ids that were never leaves (carriers, unusable ones) are fine: lenient.
  auto report = hierarchy_->apply(upserts, removed, /*lenient_removes=*/true);
  if (!report) return Status(report.error());
  log_changes(*report);
  return Status(Ok{});
}

}  // namespace gauss
