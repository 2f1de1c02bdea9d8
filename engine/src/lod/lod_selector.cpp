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
    : LodSelector(std::make_shared<LodEpochHierarchy>(sh_degree, lod), selector) {}

LodSelector::LodSelector(std::shared_ptr<LodEpochHierarchy> shared, SelectorConfig selector)
    : source_(std::move(shared)), seen_lineage_(source_->lineage()), cutter_(selector) {
  cutter_.share_layouts(source_->layouts());
}

Status LodSelector::update(const SceneStore& scene, const EligibleSet* eligible) {
  const Status status = source_->update(scene, eligible);
  learn_changes();
  return status;
}

bool LodSelector::follow(const SceneStore& scene) {
  if (source_->progress(scene) != LodEpochHierarchy::Progress::Ready) return false;
  learn_changes();
  return true;
}

void LodSelector::learn_changes() {
  // What this selector's differ must re-quantise: the interior ids the updates since it last
  // looked changed. Before its first cut it holds none, so there is nothing to learn.
  const std::uint64_t updates = source_->updates();
  if (seen_updates_ && !source_->changes_since(*seen_updates_, modified_)) {
    // It skipped more updates than the log keeps (a session held back by its link): every
    // interior record its client holds, all from its last cut, counts as changed.
    if (cut_used_) {
      const LodCut& last = cutter_.last();
      for (std::size_t k = last.leaves; k < last.ids.size(); ++k) modified_.push_back(GaussianId{last.ids[k]});
    }
  }
  seen_updates_ = updates;
  if (source_->lineage() != seen_lineage_) {
    // Built from scratch or dropped: the last cut's node indices name nothing any more.
    seen_lineage_ = source_->lineage();
    cutter_.clear_previous();
    cut_used_ = false;
  }
}

std::span<const Gaussian> LodSelector::records() const {
  const LodHierarchy* h = source_->hierarchy();
  return h ? h->record_pool() : std::span<const Gaussian>{};
}

const LodCut& LodSelector::last_cut() const {
  static const LodCut kNone;
  return cut_used_ ? cutter_.last() : kNone;
}

const Gaussian* LodSelector::find_interior(GaussianId id) const {
  // Called outside the ticks too (a session's sent records, by whoever holds it): a background
  // update writes the hierarchy, so let it finish.
  source_->wait_idle();
  const LodHierarchy* hierarchy = source_->hierarchy();
  if (!hierarchy || !cut_used_) return nullptr;
  // The cut's interior nodes, in ascending id order after its leaves.
  const LodCut& cut = cutter_.last();
  const auto first = cut.ids.begin() + static_cast<std::ptrdiff_t>(cut.leaves);
  const auto it = std::lower_bound(first, cut.ids.end(), to_underlying(id));
  if (it == cut.ids.end() || *it != to_underlying(id)) return nullptr;
  const std::uint32_t node = cut.nodes[static_cast<std::size_t>(it - cut.ids.begin())];
  if (node >= hierarchy->nodes().size()) return nullptr;
  const LodNode& n = hierarchy->node(node);
  if (!n.live || n.leaf || n.id != id) return nullptr;
  return &hierarchy->record(n);
}

Expected<Selection> LodSelector::select(Selector& selector, const SceneStore& scene, const EligibleSet* eligible,
                                        const ClientPose& pose, const SelectionRequest& request) {
  SelectionRequest req = request;
  req.background_leaves = !source_->hierarchy();  // a cut will stand in for the background's leaves
  if (!req.background_leaves && !request.query && !eligible && !scene.in_epoch() &&
      scene.appearance_count() > request.budget) {
    // No reservation and a cut for the whole background: all the Selector would give is the
    // background's count, and for that it built its per-Gaussian terms at every new epoch
    // (an O(N) pass, 32 ms at 1M on the serving thread). Without an eligibility filter the
    // count is the scene's appearance Gaussians (between epochs the span holds the live ones
    // alone, and a store no non-finite position). The Selector is left as its reservation-only
    // call leaves it: nothing resident.
    if (Status st = validate_request(request); !st) return st.error();
    Selection leaves;
    leaves.epoch = scene.epoch();
    leaves.scene_size = scene.gaussians().size();
    leaves.budget = request.budget;
    leaves.background_candidates = scene.appearance_count();
    selector.set_resident({});
    return select(std::move(leaves), scene, pose, request);
  }
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
  const LodHierarchy* hierarchy = source_->hierarchy();
  if (!hierarchy || leaves.background_candidates <= background_budget) return leaves;
  if (source_->epoch() != leaves.epoch || source_->epoch() != scene.epoch())
    return Error{"LoD: the hierarchy is at another epoch than the selection (call update() first)"};
  std::vector<ObjectId> excluded;
  if (leaves.query) excluded = leaves.query->ids();
  if (Status st = cutter_.cut_in_place(*hierarchy, pose, background_budget, excluded); !st)
    return Error{"LoD cut: " + st.message()};
  const LodCut& cut = cutter_.last();

  const auto gaussians = scene.gaussians();
  const Gaussian* base = gaussians.data();
  if (gaussians.size() + hierarchy->record_pool().size() > std::size_t{0xFFFFFFFFu})
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
