// Selector: partitioned, layered top-k selection with hysteresis (see selector.h).
#include "gauss/engine/selector.h"

#include <algorithm>
#include <mutex>
#include <bit>
#include <cmath>
#include <cstring>
#include <string>
#include <utility>

#include <glm/mat3x3.hpp>

#include "select/top_k.h"
#include "select/view_score.h"

namespace gauss {

ClientPose ClientPose::from_camera(const Camera& camera) {
  const glm::dmat3 r_cw(camera.world_to_camera);  // upper 3x3: world -> camera rotation
  const glm::dvec3 t(camera.world_to_camera[3]);
  const glm::dmat3 r_wc = glm::transpose(r_cw);
  ClientPose p;
  p.position = -(r_wc * t);
  p.orientation = glm::quat_cast(r_wc);
  const double w = camera.width > 0 ? camera.width : 1.0;
  const double h = camera.height > 0 ? camera.height : 1.0;
  // The wider side of the principal point bounds the FOV on each axis.
  p.tan_half_fov_x = camera.fx > 0 ? std::max(camera.cx, w - camera.cx) / camera.fx : 1.0;
  p.tan_half_fov_y = camera.fy > 0 ? std::max(camera.cy, h - camera.cy) / camera.fy : 1.0;
  return p;
}

Status validate_request(const SelectionRequest& r) {
  if (r.budget == 0) return Error{"selection: budget M is 0"};
  if (r.budget > r.client_capacity) {
    return Error{"selection: budget M = " + std::to_string(r.budget) + " exceeds the client's capacity of " +
                 std::to_string(r.client_capacity) + " slots"};
  }
  if (!(r.rho >= 0.0 && r.rho <= 1.0)) {  // also rejects NaN
    return Error{"selection: reservation fraction rho = " + std::to_string(r.rho) + " is outside [0, 1]"};
  }
  return Ok{};
}

Status validate_client_pose(const ClientPose& p) {
  const bool finite = std::isfinite(p.position.x) && std::isfinite(p.position.y) && std::isfinite(p.position.z) &&
                      std::isfinite(p.orientation.w) && std::isfinite(p.orientation.x) &&
                      std::isfinite(p.orientation.y) && std::isfinite(p.orientation.z);
  if (!finite) return Error{"selection: client pose is not finite"};
  if (glm::length(p.orientation) < 1e-6) return Error{"selection: client orientation is a zero quaternion"};
  if (!(p.tan_half_fov_x > 0.0 && p.tan_half_fov_y > 0.0) || !std::isfinite(p.tan_half_fov_x) ||
      !std::isfinite(p.tan_half_fov_y)) {
    return Error{"selection: client FOV must be finite and > 0"};
  }
  return Ok{};
}

Status validate_selector_config(const SelectorConfig& c) {
  auto bad = [](const char* field, double v) {
    return Status(Error{std::string("selector config: ") + field + " = " + std::to_string(v) + " is out of range"});
  };
  if (!(c.global_fraction >= 0.0 && c.global_fraction <= 1.0)) return bad("global_fraction", c.global_fraction);
  if (!(c.retention_bonus >= 0.0 && c.retention_bonus <= 100.0)) return bad("retention_bonus", c.retention_bonus);
  if (!(c.margin_deg >= 0.0 && c.margin_deg <= 90.0)) return bad("margin_deg", c.margin_deg);
  if (!(c.out_of_view_weight > 0.0 && c.out_of_view_weight <= 1.0)) {
    return bad("out_of_view_weight", c.out_of_view_weight);
  }
  if (!(c.near_distance > 0.0 && std::isfinite(c.near_distance))) return bad("near_distance", c.near_distance);
  return Ok{};
}

namespace {

float sigmoid(float x) { return 1.0f / (1.0f + std::exp(-x)); }

// Partition codes per Gaussian.
constexpr std::uint8_t kExcluded = 0;
constexpr std::uint8_t kBackground = 1;
constexpr std::uint8_t kObject = 2;

// What the cached partitions and global layer were computed for.
struct PartitionKey {
  std::uint64_t generation{0};
  std::vector<ObjectId> query;
  std::uint64_t mask_hash{0};
  std::size_t mask_size{0};
  std::size_t budget{0};
  double rho{0.0};
  bool operator==(const PartitionKey&) const = default;
};

// FNV-1a over the eligibility mask, 8 bytes at a time (a pass over N bytes, far cheaper
// than recomputing the partitions).
std::uint64_t mask_hash(std::span<const std::uint8_t> m) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  std::size_t i = 0;
  for (; i + 8 <= m.size(); i += 8) {
    std::uint64_t w;
    std::memcpy(&w, m.data() + i, 8);
    h = (h ^ w) * 0x100000001b3ull;
  }
  for (; i < m.size(); ++i) h = (h ^ m[i]) * 0x100000001b3ull;
  return h;
}

}  // namespace

// Static per-Gaussian terms (structure of arrays), valid for one scene version. Every
// array is indexed by the Gaussian's rank in ascending id order ("position" j), not by
// its index in the span: a pose update then reads and writes everything sequentially,
// ties by id are ties by position, and the selection comes out sorted by id without a
// sort or a random-access pass over the scene. Never written once built, so the Selectors
// of sessions reading one scene share them (SelectorTerms).
struct Selector::StaticTerms {
  std::uint64_t version{0};
  const Gaussian* data{nullptr};
  std::size_t n{0};
  std::vector<float> px, py, pz, radius, weight;
  std::vector<std::uint64_t> ids;     // ascending
  std::vector<std::int32_t> object;
  std::vector<std::uint8_t> carrier;
  std::vector<std::uint32_t> global_key;  // score_key(global utility)
  // Span index of position j; empty when the span is already sorted by id (identity).
  std::vector<std::uint32_t> index_of;
  std::uint32_t span_index(std::size_t j) const {
    return index_of.empty() ? static_cast<std::uint32_t>(j) : index_of[j];
  }
  bool matches(std::span<const Gaussian> g, std::uint64_t v) const {
    return version == v && data == g.data() && n == g.size();
  }
  void build(std::span<const Gaussian> g, std::uint64_t v);
};

struct SelectorTerms::Impl {
  std::mutex mutex;
  std::shared_ptr<const Selector::StaticTerms> latest;
  std::uint64_t builds{0};
};

SelectorTerms::SelectorTerms() : impl_(std::make_unique<Impl>()) {}
SelectorTerms::~SelectorTerms() = default;

std::uint64_t SelectorTerms::builds() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->builds;
}

struct Selector::Impl {
  SelectorConfig config;
  std::shared_ptr<const StaticTerms> terms;  // null until the first selection
  std::shared_ptr<SelectorTerms> shared;     // null: terms are this selector's own

  // Brings `terms` to this span and version: the shared set (built by whichever selector
  // asks first) or its own, rebuilt in place when nobody else holds it.
  void adopt_terms(std::span<const Gaussian> g, std::uint64_t v) {
    if (shared) {
      std::lock_guard lock(shared->impl_->mutex);
      auto& latest = shared->impl_->latest;
      if (!latest || !latest->matches(g, v)) {
        auto fresh = std::make_shared<StaticTerms>();
        fresh->build(g, v);
        latest = std::move(fresh);
        ++shared->impl_->builds;
      }
      terms = latest;
    } else {
      std::shared_ptr<StaticTerms> own = std::const_pointer_cast<StaticTerms>(std::move(terms));
      if (!own || own.use_count() > 1) own = std::make_shared<StaticTerms>();
      own->build(g, v);
      terms = std::move(own);
    }
    ++generation;
    partition_valid = false;
  }

  // Per-call scratch, kept between calls so a warm selector does not allocate.
  std::uint64_t generation{0};  // bumped at every new set of terms
  std::vector<std::uint8_t> part;         // partition code per position
  std::vector<std::uint8_t> view_part;    // part, or kExcluded where the global layer took it
  std::vector<std::uint8_t> selected, global_flags;
  std::vector<std::uint32_t> view_key;
  // Cached partition + global layer (see select()).
  bool partition_valid{false};
  PartitionKey partition_key;
  std::size_t n_obj{0}, n_bg{0}, object_budget{0}, bg_budget{0};
  std::size_t global_obj{0}, global_bg{0};
  // The background's global layer and view_part are made only for a request with the
  // background's leaves: with a LoD cut standing in for them, every new scene version cost
  // each session a ranking of all N for nothing.
  bool background_layer_valid{false};
  std::vector<std::uint8_t> eligible_mask;  // EligibleSet indices as a mask
  // Hysteresis state: the resident ids, and the same as a flag per position of the cached
  // scene version (the previous selection's flags when the version did not change, so a
  // pose-only update needs no id lookups). resident_flags_valid is false after a rebuild
  // or set_resident(); the flags are then recomputed from the ids once, by one merge of
  // the sorted resident ids with the (sorted) position ids.
  std::vector<GaussianId> resident_ids;
  std::vector<std::uint8_t> resident_flags;
  bool resident_flags_valid{false};
  // After a select() the resident set is held as flags only (copying M ids per call
  // would cost more than the lookups it saves); resident_ids is filled from them when a
  // rebuild is about to replace the positions they refer to.
  bool resident_ids_from_flags{false};
  void materialise_resident_ids() {
    if (!resident_ids_from_flags) return;
    resident_ids.clear();
    for (std::size_t j = 0; j < resident_flags.size(); ++j)
      if (resident_flags[j]) resident_ids.push_back(GaussianId{terms->ids[j]});
    resident_ids_from_flags = false;
  }
  select_detail::TopK top;
  std::vector<std::uint8_t> object_flags;  // object id -> in query (ids < kFlagLimit)

  // The query's partition alone, gathered (for a request without the background's leaves):
  // its positions ascending and their terms, so a pose update scores and ranks the object's
  // Gaussians instead of all N. Valid with the partition it was gathered from.
  struct ObjectTerms {
    bool valid{false};
    std::vector<std::uint32_t> pos;  // ascending positions j with part[j] == kObject
    std::vector<float> px, py, pz, radius, weight;
    std::vector<std::uint8_t> part, view_part, global;  // part (all kObject), view_part, global flags
    std::vector<std::uint8_t> resident, selected;
    std::vector<std::uint32_t> view_key;
  } object_terms;

  void gather_object_terms() {
    const StaticTerms& t = *terms;
    const std::size_t n = t.n;
    ObjectTerms& o = object_terms;
    o.pos.clear();
    for (std::size_t j = 0; j < n && o.pos.size() < n_obj; ++j)
      if (part[j] == kObject) o.pos.push_back(static_cast<std::uint32_t>(j));
    const std::size_t m = o.pos.size();
    for (auto* v : {&o.px, &o.py, &o.pz, &o.radius, &o.weight}) v->resize(m);
    for (auto* v : {&o.part, &o.view_part, &o.global}) v->resize(m);
    for (std::size_t i = 0; i < m; ++i) {
      const std::uint32_t j = o.pos[i];
      o.px[i] = t.px[j];
      o.py[i] = t.py[j];
      o.pz[i] = t.pz[j];
      o.radius[i] = t.radius[j];
      o.weight[i] = t.weight[j];
      o.part[i] = part[j];
      o.view_part[i] = global_flags[j] ? kExcluded : part[j];  // view_part's entry
      o.global[i] = global_flags[j];
    }
    o.valid = true;
  }

};

void Selector::StaticTerms::build(std::span<const Gaussian> g, std::uint64_t v) {
  n = g.size();
  // Terms are computed in span order (one sequential pass over the Gaussians), then
  // each array is permuted into id order: gathering from the small arrays is far
  // cheaper than reading the large Gaussians in id order.
  px.resize(n);
  py.resize(n);
  pz.resize(n);
  radius.resize(n);
  weight.resize(n);
  ids.resize(n);
  object.resize(n);
  carrier.resize(n);
  global_key.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Gaussian& x = g[i];
    ids[i] = to_underlying(x.id);
    object[i] = to_underlying(x.object);
    carrier[i] = x.carrier ? 1 : 0;
    px[i] = x.position.x;
    py[i] = x.position.y;
    pz[i] = x.position.z;
    // 3 sigma of the largest axis: the extent a renderer would touch.
    const float r = 3.0f * std::exp(std::max({x.log_scale.x, x.log_scale.y, x.log_scale.z}));
    radius[i] = std::isfinite(r) ? r : 0.0f;
    // Support enters logarithmically: well-observed Gaussians win, but a tenfold
    // support does not beat a tenfold opacity.
    const float w = sigmoid(x.opacity_logit) * (1.0f + std::log2(1.0f + static_cast<float>(x.support)));
    weight[i] = std::isfinite(w) ? w : 0.0f;
    float global_utility = weight[i] * radius[i];
    // A non-finite position cannot be ranked: it never enters (like a carrier).
    if (!std::isfinite(x.position.x) || !std::isfinite(x.position.y) || !std::isfinite(x.position.z)) {
      weight[i] = 0.0f;
      global_utility = 0.0f;
      px[i] = py[i] = pz[i] = 0.0f;
      carrier[i] = 1;
    }
    global_key[i] = select_detail::score_key(global_utility);
  }
  index_of.clear();
  if (!std::is_sorted(ids.begin(), ids.end())) {
    index_of.resize(n);
    const auto [lo, hi] = std::minmax_element(ids.begin(), ids.end());
    const std::uint64_t range = *hi - *lo;
    // Host ids are handed out sequentially, so they usually span a few times N: a
    // counting sort (one slot per id in the range) is then O(N) and several times
    // faster than a comparison sort. Equal ids (a plain span may repeat one) and wide
    // ranges take the comparison sort; both keep equal ids in span order.
    std::vector<std::uint32_t> first(range < 4 * std::uint64_t{n} ? range + 1 : 0, 0xFFFFFFFFu);
    bool unique = !first.empty();
    for (std::size_t i = 0; i < n && unique; ++i) {
      std::uint32_t& slot = first[ids[i] - *lo];
      unique = slot == 0xFFFFFFFFu;
      slot = static_cast<std::uint32_t>(i);
    }
    if (unique) {
      std::size_t j = 0;
      for (std::uint32_t i : first)
        if (i != 0xFFFFFFFFu) index_of[j++] = i;
    } else {
      // (id, span index) pairs sort without touching the Gaussians.
      std::vector<std::pair<std::uint64_t, std::uint32_t>> order(n);
      for (std::size_t i = 0; i < n; ++i) order[i] = {ids[i], static_cast<std::uint32_t>(i)};
      std::sort(order.begin(), order.end());
      for (std::size_t j = 0; j < n; ++j) index_of[j] = order[j].second;
    }
    auto permute = [&](auto& a) {
      auto tmp = a;
      for (std::size_t j = 0; j < n; ++j) a[j] = tmp[index_of[j]];
    };
    permute(px);
    permute(py);
    permute(pz);
    permute(radius);
    permute(weight);
    permute(ids);
    permute(object);
    permute(carrier);
    permute(global_key);
  }
  data = g.data();
  version = v;
}

Selector::Selector(SelectorConfig config) : impl_(std::make_unique<Impl>()) { impl_->config = config; }

void Selector::share_terms(std::shared_ptr<SelectorTerms> terms) { impl_->shared = std::move(terms); }
Selector::Selector(Selector&&) noexcept = default;
Selector& Selector::operator=(Selector&&) noexcept = default;
Selector::~Selector() = default;

const SelectorConfig& Selector::config() const { return impl_->config; }

void Selector::set_resident(std::span<const GaussianId> ids) {
  impl_->resident_ids.assign(ids.begin(), ids.end());
  impl_->resident_ids_from_flags = false;
  impl_->resident_flags_valid = false;
}

void Selector::clear_resident() {
  impl_->resident_ids.clear();
  impl_->resident_ids_from_flags = false;
  impl_->resident_flags_valid = false;
}

Expected<Selection> Selector::select(const SceneStore& scene, const ClientPose& pose, const SelectionRequest& request,
                                     std::span<const std::uint8_t> eligible) {
  if (scene.in_epoch()) return Error{"selection: the scene has an open epoch; select between epochs"};
  return select(scene.gaussians(), scene.objects(), to_underlying(scene.epoch()), scene.epoch(), pose, request,
                eligible);
}

Expected<Selection> Selector::select(const SceneStore& scene, const ClientPose& pose, const SelectionRequest& request,
                                     const EligibleSet& eligible) {
  if (eligible.epoch != scene.epoch()) {
    return Error{"selection: eligible set is from epoch " + std::to_string(to_underlying(eligible.epoch)) +
                 ", the scene is at epoch " + std::to_string(to_underlying(scene.epoch()))};
  }
  std::vector<std::uint8_t>& mask = impl_->eligible_mask;
  mask.assign(scene.gaussians().size(), 0);
  for (std::uint32_t i : eligible.indices) {
    if (i >= mask.size()) {
      return Error{"selection: eligible index " + std::to_string(i) + " outside the scene's " +
                   std::to_string(mask.size()) + " Gaussians"};
    }
    mask[i] = 1;
  }
  return select(scene, pose, request, std::span<const std::uint8_t>(mask));
}

Expected<Selection> Selector::select(std::span<const Gaussian> gaussians, std::span<const SemanticObject> objects,
                                     std::uint64_t scene_version, Epoch epoch, const ClientPose& pose,
                                     const SelectionRequest& request, std::span<const std::uint8_t> eligible) {
  if (Status st = validate_request(request); !st) return st.error();
  if (Status st = validate_client_pose(pose); !st) return st.error();
  if (Status st = validate_selector_config(impl_->config); !st) return st.error();
  if (!eligible.empty() && eligible.size() != gaussians.size()) {
    return Error{"selection: eligibility mask has " + std::to_string(eligible.size()) + " entries for " +
                 std::to_string(gaussians.size()) + " Gaussians"};
  }
  if (gaussians.size() > std::size_t{0xFFFFFFFFu}) return Error{"selection: more than 2^32 Gaussians"};
  Impl& s = *impl_;
  const SelectorConfig& cfg = s.config;

  Selection out;
  out.epoch = epoch;
  out.budget = request.budget;
  out.scene_size = gaussians.size();
  if (request.query) {
    auto res = resolve_query(*request.query, objects);
    if (!res) return res.error();
    out.query = std::move(*res);
  }
  if (!s.terms || !s.terms->matches(gaussians, scene_version)) {
    s.materialise_resident_ids();
    s.adopt_terms(gaussians, scene_version);
    s.resident_flags_valid = false;
  }
  const StaticTerms& T = *s.terms;
  if (!s.resident_flags_valid) {
    s.resident_flags.assign(T.n, 0);
    if (!s.resident_ids.empty()) {
      std::vector<GaussianId> r = s.resident_ids;
      std::sort(r.begin(), r.end());
      std::size_t a = 0;
      for (std::size_t j = 0; j < T.n && a < r.size(); ++j) {
        while (a < r.size() && to_underlying(r[a]) < T.ids[j]) ++a;
        s.resident_flags[j] = a < r.size() && to_underlying(r[a]) == T.ids[j];
      }
    }
    s.resident_flags_valid = true;
  }
  const std::size_t n = T.n;

  // Query membership by object id: a flat flag table for the usual small ids.
  constexpr std::int64_t kFlagLimit = 1 << 20;
  std::vector<ObjectId> query_ids;
  bool all_small = true;
  if (out.query) {
    query_ids = out.query->ids();
    for (ObjectId id : query_ids) all_small = all_small && to_underlying(id) < kFlagLimit;
    if (all_small) {
      const auto max_id = static_cast<std::size_t>(to_underlying(query_ids.back()));
      s.object_flags.assign(max_id + 1, 0);
      for (ObjectId id : query_ids) s.object_flags[static_cast<std::size_t>(to_underlying(id))] = 1;
    }
  }
  auto in_query = [&](std::int32_t v) {
    if (v < 0) return false;
    if (all_small) return static_cast<std::size_t>(v) < s.object_flags.size() && s.object_flags[static_cast<std::size_t>(v)];
    return std::binary_search(query_ids.begin(), query_ids.end(), ObjectId{v},
                              [](ObjectId a, ObjectId b) { return to_underlying(a) < to_underlying(b); });
  };

  // Camera frame: rows of R_head_world. Utility is 1 inside the frustum and ramps down
  // linearly to out_of_view_weight over the margin outside it. The ramp (instead of a hard
  // edge) keeps a small head turn from changing any utility by more than a few percent,
  // which the retention bonus absorbs.
  const select_detail::ViewParams vp = select_detail::make_view_params(pose, cfg);

  // Partitions and the global layer depend on the scene, the query, the eligibility mask
  // and the budgets, not on the pose: computed once and reused while those stay the same,
  // so a pose-only update pays for the view layer alone.
  PartitionKey key{s.generation, query_ids, mask_hash(eligible), eligible.size(), request.budget, request.rho};
  auto global_budget = [&](std::size_t budget) {
    return static_cast<std::size_t>(std::floor(cfg.global_fraction * static_cast<double>(budget)));
  };
  if (!s.partition_valid || !(key == s.partition_key)) {
    s.part.resize(n);
    std::size_t n_obj = 0;
    std::size_t n_bg = 0;
    for (std::size_t j = 0; j < n; ++j) {
      std::uint8_t p = kExcluded;
      if (!T.carrier[j] && (eligible.empty() || eligible[T.span_index(j)] != 0)) {
        p = (out.query && in_query(T.object[j])) ? kObject : kBackground;
      }
      s.part[j] = p;
      n_obj += p == kObject;
      n_bg += p == kBackground;
    }
    s.n_obj = n_obj;
    s.n_bg = n_bg;
    s.object_budget = 0;
    if (out.query) {
      const auto reserve = static_cast<std::size_t>(std::floor(request.rho * static_cast<double>(request.budget)));
      s.object_budget = std::min(n_obj, reserve);
    }
    s.bg_budget = std::min(n_bg, request.budget - s.object_budget);
    s.global_flags.assign(n, 0);
    s.global_obj = s.top.select(T.global_key, s.part, kObject, global_budget(s.object_budget), s.global_flags);
    s.global_bg = 0;
    s.background_layer_valid = false;
    s.partition_key = std::move(key);
    s.partition_valid = true;
    s.object_terms.valid = false;
  }
  if (request.background_leaves && !s.background_layer_valid) {
    // The background's global layer (its flags are its partition's own, so made after the
    // object's they are the same), then the view layer's partition: what the global layer left.
    s.global_bg = s.top.select(T.global_key, s.part, kBackground, global_budget(s.bg_budget), s.global_flags);
    s.view_part.resize(n);
    for (std::size_t j = 0; j < n; ++j) s.view_part[j] = s.global_flags[j] ? kExcluded : s.part[j];
    s.background_layer_valid = true;
  }
  out.object_candidates = s.n_obj;
  out.background_candidates = s.n_bg;
  out.object_budget = s.object_budget;

  if (!request.background_leaves) {
    // The reservation alone: the query's partition, gathered once per partition, is scored
    // and ranked by itself. Its positions ascend, so the tie rule (lower position) and the
    // keys are the full pass's: the same leaves.
    if (!s.object_terms.valid) s.gather_object_terms();
    Impl::ObjectTerms& o = s.object_terms;
    const std::size_t m = o.pos.size();
    o.resident.resize(m);
    for (std::size_t i = 0; i < m; ++i) o.resident[i] = s.resident_flags[o.pos[i]];
    o.selected = o.global;  // the global layer's picks of the partition
    out.global_selected = s.global_obj;
    out.object_selected = 0;
    if (s.object_budget > 0) {
      o.view_key.resize(m);
      select_detail::score_view(m, o.px.data(), o.py.data(), o.pz.data(), o.radius.data(), o.weight.data(),
                                o.part.data(), o.resident.data(), vp, o.view_key.data());
      out.object_selected =
          s.global_obj + s.top.select(o.view_key, o.view_part, kObject, s.object_budget - s.global_obj, o.selected);
    }
    out.ids.clear();
    out.indices.clear();
    out.ids.reserve(out.object_selected);
    out.indices.reserve(out.object_selected);
    // The next call's hysteresis flags: the selected positions only.
    s.resident_flags.assign(n, 0);
    std::size_t retained = 0;
    for (std::size_t i = 0; i < m; ++i) {
      if (!o.selected[i]) continue;
      const std::uint32_t j = o.pos[i];
      out.ids.push_back(GaussianId{T.ids[j]});
      out.indices.push_back(T.span_index(j));
      retained += o.resident[i];
      s.resident_flags[j] = 1;
    }
    out.retained = retained;
    s.resident_ids_from_flags = true;
    return out;
  }

  s.view_key.resize(n);
  select_detail::score_view(n, T.px.data(), T.py.data(), T.pz.data(), T.radius.data(), T.weight.data(),
                            s.part.data(), s.resident_flags.data(), vp, s.view_key.data());
  s.selected = s.global_flags;  // same size: a copy, no allocation once warm
  out.global_selected = s.global_obj + s.global_bg;
  auto fill = [&](std::uint8_t p, std::size_t budget, std::size_t global) {
    return global + s.top.select(s.view_key, s.view_part, p, budget - global, s.selected);
  };
  out.object_selected = s.object_budget > 0 ? fill(kObject, s.object_budget, s.global_obj) : 0;
  out.background_selected = s.bg_budget > 0 ? fill(kBackground, s.bg_budget, s.global_bg) : 0;

  // The set in ascending id order: positions are id ranks, so one sequential pass. About
  // four in five flags are 0 at M = N / 5: skip zero words eight flags at a time.
  const std::size_t total = out.object_selected + out.background_selected;
  out.ids.resize(total);
  out.indices.resize(total);
  GaussianId* out_id = out.ids.data();
  std::uint32_t* out_index = out.indices.data();
  std::size_t t = 0;
  std::size_t retained = 0;
  const std::uint8_t* sel = s.selected.data();
  // t < total always holds (the layers marked exactly `total` flags); the bound keeps a
  // broken invariant from writing past the output.
  for (std::size_t j = 0; j < n && t < total;) {
    if (j + 8 <= n) {
      std::uint64_t w;
      std::memcpy(&w, sel + j, 8);
      if (w == 0) {
        j += 8;
        continue;
      }
    }
    const std::size_t end = std::min(n, j + 8);
    for (; j < end && t < total; ++j) {
      if (!sel[j]) continue;
      out_id[t] = GaussianId{T.ids[j]};
      out_index[t] = T.span_index(j);
      retained += s.resident_flags[j];
      ++t;
    }
  }
  out.ids.resize(t);
  out.indices.resize(t);
  out.retained = retained;
  // Same version next time: these flags are the next call's hysteresis state, no id
  // lookups; the ids are only materialised if the scene changes first (see select()).
  s.resident_flags.swap(s.selected);
  s.resident_ids_from_flags = true;
  return out;
}

}  // namespace gauss
