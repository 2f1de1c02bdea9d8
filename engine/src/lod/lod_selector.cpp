// LodSelector: leaf selection for the reservation, a LoD cut for the background
// (lod_selector.h).
#include "gauss/engine/lod_selector.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <string>
#include <utility>

#include <glm/geometric.hpp>

namespace gauss {

LodSelector::LodSelector(int sh_degree, SelectorConfig selector, LodConfig lod)
    : sh_degree_(sh_degree), lod_config_(lod), cutter_(selector) {}

Status LodSelector::update(const SceneStore& scene, const EligibleSet* eligible) {
  if (scene.in_epoch()) return Error{"LoD: the scene has an open epoch; update between epochs"};
  // Once per epoch: a failed update is not retried (and reported again) every tick.
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
      return *applied ? Status(Ok{}) : drop_hierarchy(scene, applied->message());
    }
  }
  subset_.clear();
  if (eligible) {
    subset_.assign(eligible->indices.begin(), eligible->indices.end());
  } else {
    for (std::size_t i = 0; i < gaussians.size(); ++i)
      if (!gaussians[i].carrier) subset_.push_back(static_cast<std::uint32_t>(i));
  }
  const bool fresh = !hierarchy_;
  if (fresh) {
    auto h = LodHierarchy::create(sh_degree_, lod_config_);
    if (!h) return Error{"LoD: " + h.message()};
    hierarchy_ = std::move(*h);
  }
  auto report = hierarchy_->update(gaussians, subset_);
  epoch_ = scene.epoch();
  if (!report) return drop_hierarchy(scene, report.message());
  if (fresh) cutter_.clear_previous();
  last_failure_.clear();
  note_changes(*report);
  return Ok{};
}

Status LodSelector::drop_hierarchy(const SceneStore& scene, const std::string& why) {
  hierarchy_.reset();
  cutter_.clear_previous();
  cut_used_ = false;
  // Said once per reason: a scene that keeps the cause (an id with the top bit, say) would
  // otherwise log a line every epoch.
  if (why == last_failure_) return Ok{};
  last_failure_ = why;
  return Error{"LoD: no hierarchy for epoch " + std::to_string(to_underlying(scene.epoch())) + ": " + why +
               "; selecting leaves until it can be built"};
}

void LodSelector::note_changes(const LodUpdateReport& report) {
  // Modified records are re-quantised by the differ; retired ones leave the next cut (the
  // differ removes them as leavers), listed too so a stale pool slot is never trusted; added
  // ones too: a hierarchy built again after a fallback counts its serials from 0, so a new node
  // may carry an id the client held before (the fallback's leaf batch removed those; this
  // keeps the differ from trusting an old record if one ever stays).
  modified_.insert(modified_.end(), report.modified.begin(), report.modified.end());
  modified_.insert(modified_.end(), report.removed.begin(), report.removed.end());
  modified_.insert(modified_.end(), report.added.begin(), report.added.end());
}

std::optional<Status> LodSelector::apply_change_log(const SceneStore& scene) {
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
  note_changes(*report);
  return Status(Ok{});
}

std::span<const Gaussian> LodSelector::records() const {
  return hierarchy_ ? hierarchy_->record_pool() : std::span<const Gaussian>{};
}

const LodCut& LodSelector::last_cut() const {
  static const LodCut kNone;
  return cut_used_ ? cutter_.last() : kNone;
}

const Gaussian* LodSelector::find_interior(GaussianId id) const {
  if (!hierarchy_ || !cut_used_) return nullptr;
  // The cut's interior nodes, in ascending id order after its leaves.
  const LodCut& cut = cutter_.last();
  const auto first = cut.ids.begin() + static_cast<std::ptrdiff_t>(cut.leaves);
  const auto it = std::lower_bound(first, cut.ids.end(), to_underlying(id));
  if (it == cut.ids.end() || *it != to_underlying(id)) return nullptr;
  const LodNode& n = hierarchy_->node(cut.nodes[static_cast<std::size_t>(it - cut.ids.begin())]);
  if (!n.live || n.leaf || n.id != id) return nullptr;
  return &hierarchy_->record(n);
}

Expected<Selection> LodSelector::select(Selector& selector, const SceneStore& scene, const EligibleSet* eligible,
                                        const ClientPose& pose, const SelectionRequest& request) {
  SelectionRequest req = request;
  req.background_leaves = !hierarchy_;  // a cut will stand in for the background's leaves
  auto run = [&] { return eligible ? selector.select(scene, pose, req, *eligible) : selector.select(scene, pose, req); };
  auto leaves = run();
  if (!leaves) return leaves;
  if (!req.background_leaves &&
      leaves->background_candidates <= request.budget - std::min(request.budget, leaves->object_selected)) {
    // Everything fits: no cut, the leaf selection itself (the Selector's counts are cached,
    // so the first call cost little).
    req.background_leaves = true;
    leaves = run();
    if (!leaves) return leaves;
  }
  return select(std::move(*leaves), scene, pose, request);
}

Expected<Selection> LodSelector::select(Selection leaves, const SceneStore& scene, const ClientPose& pose,
                                        const SelectionRequest& request) {
  const std::size_t background_budget = request.budget - std::min(request.budget, leaves.object_selected);
  cut_used_ = false;
  if (!hierarchy_ || leaves.background_candidates <= background_budget) return leaves;
  if (epoch_ != leaves.epoch || epoch_ != scene.epoch())
    return Error{"LoD: the hierarchy is at another epoch than the selection (call update() first)"};
  std::vector<ObjectId> excluded;
  if (leaves.query) excluded = leaves.query->ids();
  if (Status st = cutter_.cut_in_place(*hierarchy_, pose, background_budget, excluded); !st)
    return Error{"LoD cut: " + st.message()};
  const LodCut& cut = cutter_.last();

  const auto gaussians = scene.gaussians();
  const Gaussian* base = gaussians.data();
  if (gaussians.size() + hierarchy_->record_pool().size() > std::size_t{0xFFFFFFFFu})
    return Error{"LoD: scene and hierarchy records exceed 2^32 indices"};
  // The reservation's leaves, in id order as the Selector wrote them (with
  // background_leaves false, they are all it wrote).
  auto& reserved = chosen_;  // kept between calls
  reserved.clear();
  if (leaves.query && leaves.background_selected == 0) {
    // Asked without the background's leaves: every leaf is the reservation's.
    for (std::size_t k = 0; k < leaves.ids.size(); ++k)
      reserved.emplace_back(to_underlying(leaves.ids[k]), leaves.indices[k]);
  } else if (leaves.query) {
    for (std::size_t k = 0; k < leaves.ids.size(); ++k) {
      const ObjectId o = gaussians[leaves.indices[k]].object;
      if (std::binary_search(excluded.begin(), excluded.end(), o,
                             [](ObjectId a, ObjectId b) { return to_underlying(a) < to_underlying(b); }))
        reserved.emplace_back(to_underlying(leaves.ids[k]), leaves.indices[k]);
    }
  }
  Selection out = std::move(leaves);
  out.ids.resize(reserved.size() + cut.nodes.size());
  out.indices.resize(out.ids.size());
  // The cut's leaves come in id order, then its interior nodes (lod_cut.h): the reservation
  // merges in as they are written out.
  std::size_t t = 0, r = 0;
  auto put = [&](std::uint64_t id, std::uint32_t index) {
    out.ids[t] = GaussianId{id};
    out.indices[t++] = index;
  };
  for (std::size_t k = 0; k < cut.leaves; ++k) {
    const std::uint64_t id = cut.ids[k];
    for (; r < reserved.size() && reserved[r].first < id; ++r) put(reserved[r].first, reserved[r].second);
    // Where the hierarchy last saw the leaf, without reading the Gaussian (a cache miss per
    // leaf was a third of the assembly at 1M). That place still holds it or lies beyond the
    // scene: a commit fills a removed Gaussian's place with the scene's last one, so only
    // Gaussians from the tail move, and a leaf placed by apply() has none. The differ checks
    // the id of every record it reads.
    std::uint32_t index = cut.places[k];
    if (index >= gaussians.size()) {
      const Gaussian* g = scene.find(GaussianId{id});
      if (!g) return Error{"LoD: cut leaf " + std::to_string(id) + " is not in the scene"};
      index = static_cast<std::uint32_t>(g - base);
    }
    put(id, index);
  }
  for (; r < reserved.size(); ++r) put(reserved[r].first, reserved[r].second);
  const auto scene_size = static_cast<std::uint32_t>(gaussians.size());
  for (std::size_t k = cut.leaves; k < cut.nodes.size(); ++k) put(cut.ids[k], scene_size + cut.places[k]);
  cut_used_ = true;
  out.background_selected = cut.nodes.size();
  out.lod_interior = cut.interior;
  return out;
}

CodecParams fit_lod_codec_params(CodecParams params, const LodMergeConfig& merge) {
  const glm::dvec3 half = 0.5 * (glm::dvec3(params.box.max) - glm::dvec3(params.box.min));
  const double h2 = glm::dot(half, half);
  const double widest = std::exp(2.0 * double(params.log_scale_max));
  const double bound = 0.5 * std::log(widest + merge.spread * merge.spread * h2);
  if (std::isfinite(bound)) params.log_scale_max = std::max(params.log_scale_max, float(bound));
  return params;
}

}  // namespace gauss
