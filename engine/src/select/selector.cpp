// Selector: partitioned, layered top-k selection with hysteresis (see selector.h).
#include "gauss/engine/selector.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>
#include <string>

#include <glm/mat3x3.hpp>

#include "select/id_table.h"
#include "select/top_k.h"

namespace gauss {

using select_detail::IdTable;

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

namespace {

Status validate_pose(const ClientPose& p) {
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

float sigmoid(float x) { return 1.0f / (1.0f + std::exp(-x)); }

// Partition codes per Gaussian.
constexpr std::uint8_t kExcluded = 0;
constexpr std::uint8_t kBackground = 1;
constexpr std::uint8_t kObject = 2;

}  // namespace

struct Selector::Impl {
  SelectorConfig config;

  // Static per-Gaussian terms (structure of arrays), valid for one scene version.
  bool cached{false};
  std::uint64_t version{0};
  const Gaussian* data{nullptr};
  std::size_t n{0};
  std::vector<float> px, py, pz, radius, weight, global_utility;
  std::vector<std::uint64_t> ids;

  // Per-call scratch, kept between calls so a warm selector does not allocate.
  std::vector<std::uint8_t> part, selected, resident_now;
  std::vector<std::uint32_t> view_key, global_key;
  select_detail::TopK top;
  std::vector<std::uint8_t> object_flags;  // object id -> in query (ids < kFlagLimit)
  IdTable<std::uint8_t> resident;

  void rebuild(std::span<const Gaussian> g, std::uint64_t v) {
    n = g.size();
    px.resize(n);
    py.resize(n);
    pz.resize(n);
    radius.resize(n);
    weight.resize(n);
    global_utility.resize(n);
    ids.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const Gaussian& x = g[i];
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
      global_utility[i] = weight[i] * radius[i];
      ids[i] = to_underlying(x.id);
    }
    data = g.data();
    version = v;
    cached = true;
  }
};

Selector::Selector(SelectorConfig config) : impl_(std::make_unique<Impl>()) { impl_->config = config; }
Selector::Selector(Selector&&) noexcept = default;
Selector& Selector::operator=(Selector&&) noexcept = default;
Selector::~Selector() = default;

const SelectorConfig& Selector::config() const { return impl_->config; }

void Selector::set_resident(std::span<const GaussianId> ids) {
  impl_->resident.clear();
  for (GaussianId id : ids) impl_->resident.set(id, 1);
}

void Selector::clear_resident() { impl_->resident.clear(); }

Expected<Selection> Selector::select(const SceneStore& scene, const ClientPose& pose, const SelectionRequest& request,
                                     std::span<const std::uint8_t> eligible) {
  if (scene.in_epoch()) return Error{"selection: the scene has an open epoch; select between epochs"};
  return select(scene.gaussians(), scene.objects(), to_underlying(scene.epoch()), scene.epoch(), pose, request,
                eligible);
}

Expected<Selection> Selector::select(std::span<const Gaussian> gaussians, std::span<const SemanticObject> objects,
                                     std::uint64_t scene_version, Epoch epoch, const ClientPose& pose,
                                     const SelectionRequest& request, std::span<const std::uint8_t> eligible) {
  if (Status st = validate_request(request); !st) return st.error();
  if (Status st = validate_pose(pose); !st) return st.error();
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
  if (!s.cached || s.version != scene_version || s.data != gaussians.data() || s.n != gaussians.size()) {
    s.rebuild(gaussians, scene_version);
  }
  const std::size_t n = s.n;

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
  auto in_query = [&](ObjectId o) {
    const std::int32_t v = to_underlying(o);
    if (v < 0) return false;
    if (all_small) return static_cast<std::size_t>(v) < s.object_flags.size() && s.object_flags[static_cast<std::size_t>(v)];
    return std::binary_search(query_ids.begin(), query_ids.end(), o,
                              [](ObjectId a, ObjectId b) { return to_underlying(a) < to_underlying(b); });
  };

  // Camera frame: rows of R_head_world. Utility is 1 inside the frustum and ramps down
  // linearly to out_of_view_weight over the margin outside it. The ramp (instead of a hard
  // edge) keeps a small head turn from changing any utility by more than a few percent,
  // which the retention bonus absorbs.
  const glm::dmat3 r_wh = glm::mat3_cast(glm::normalize(pose.orientation));
  const glm::dmat3 r_hw = glm::transpose(r_wh);
  const float ftx = static_cast<float>(pose.tan_half_fov_x);
  const float fty = static_cast<float>(pose.tan_half_fov_y);
  const float kx = static_cast<float>(std::sqrt(1.0 + pose.tan_half_fov_x * pose.tan_half_fov_x));
  const float ky = static_cast<float>(std::sqrt(1.0 + pose.tan_half_fov_y * pose.tan_half_fov_y));
  // Outside-ness e = (distance of the sphere beyond a side plane) / distance ~ sine of the
  // angle outside; the ramp spans e in [0, sin(margin)].
  const float ramp = static_cast<float>(std::sin(std::clamp(cfg.margin_deg, 0.1, 90.0) * std::numbers::pi / 180.0));
  const float inv_ramp = 1.0f / ramp;
  // Row i of r_hw maps world offsets to head axis i (GLM is column-major: m[col][row]).
  float row[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) row[i][j] = static_cast<float>(r_hw[j][i]);
  const double cx = pose.position.x, cy = pose.position.y, cz = pose.position.z;
  const float near = static_cast<float>(cfg.near_distance);
  const float out_w = static_cast<float>(cfg.out_of_view_weight);
  const float bonus = static_cast<float>(1.0 + cfg.retention_bonus);

  s.part.resize(n);
  s.selected.assign(n, 0);
  s.resident_now.resize(n);
  s.view_key.resize(n);
  s.global_key.resize(n);
  std::size_t n_obj = 0;
  std::size_t n_bg = 0;
  const bool have_resident = s.resident.size() > 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Gaussian& g = gaussians[i];
    std::uint8_t p = kExcluded;
    if (!g.carrier && (eligible.empty() || eligible[i] != 0)) p = (out.query && in_query(g.object)) ? kObject : kBackground;
    s.part[i] = p;
    if (p == kExcluded) {
      s.view_key[i] = 0;
      s.global_key[i] = 0;
      continue;
    }
    (p == kObject ? n_obj : n_bg) += 1;
    const bool res = have_resident && s.resident.contains(GaussianId{s.ids[i]});
    s.resident_now[i] = res ? 1 : 0;
    const float keep = res ? bonus : 1.0f;
    // Offsets in double then float: positions far from the origin keep their precision.
    const float dx = static_cast<float>(s.px[i] - cx);
    const float dy = static_cast<float>(s.py[i] - cy);
    const float dz = static_cast<float>(s.pz[i] - cz);
    const float hx = row[0][0] * dx + row[0][1] * dy + row[0][2] * dz;
    const float hy = row[1][0] * dx + row[1][1] * dy + row[1][2] * dz;
    const float hz = row[2][0] * dx + row[2][1] * dy + row[2][2] * dz;
    const float r = s.radius[i];
    const float dist = std::max(std::sqrt(dx * dx + dy * dy + dz * dz), near);
    // Signed distances beyond the side planes (normalised by the plane normals' length).
    const float ex = (std::fabs(hx) - ftx * hz) / kx - r;
    const float ey = (std::fabs(hy) - fty * hz) / ky - r;
    const float outside = std::max(ex, ey) / dist;
    const float facing = outside <= 0.0f ? 1.0f : std::max(out_w, 1.0f - (1.0f - out_w) * outside * inv_ramp);
    const float view = s.weight[i] * (r / dist) * facing * keep;
    s.view_key[i] = select_detail::score_key(view);
    s.global_key[i] = select_detail::score_key(s.global_utility[i] * keep);
  }
  out.object_candidates = n_obj;
  out.background_candidates = n_bg;
  const std::size_t m = request.budget;
  if (out.query) {
    const auto reserve = static_cast<std::size_t>(std::floor(request.rho * static_cast<double>(m)));
    out.object_budget = std::min(n_obj, reserve);
  }
  const std::size_t bg_budget = std::min(n_bg, m - out.object_budget);

  auto fill = [&](std::uint8_t p, std::size_t budget) {
    const auto global_budget = static_cast<std::size_t>(std::floor(cfg.global_fraction * static_cast<double>(budget)));
    auto pred = [&](std::size_t i) { return s.part[i] == p && !s.selected[i]; };
    const std::size_t g = s.top.select(s.global_key, s.ids, pred, global_budget, s.selected);
    out.global_selected += g;
    const std::size_t v = s.top.select(s.view_key, s.ids, pred, budget - g, s.selected);
    return g + v;
  };
  out.object_selected = out.object_budget > 0 ? fill(kObject, out.object_budget) : 0;
  out.background_selected = bg_budget > 0 ? fill(kBackground, bg_budget) : 0;

  // The set in scene order (ascending ids for a SceneStore fed with allocate_id()).
  const std::size_t total = out.object_selected + out.background_selected;
  out.ids.reserve(total);
  out.indices.reserve(total);
  for (std::size_t i = 0; i < n; ++i) {
    if (!s.selected[i]) continue;
    out.indices.push_back(static_cast<std::uint32_t>(i));
    out.ids.push_back(GaussianId{s.ids[i]});
    out.retained += s.resident_now[i];
  }
  if (!std::is_sorted(out.ids.begin(), out.ids.end())) {
    std::vector<std::uint32_t> order(out.indices);
    std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return s.ids[a] < s.ids[b]; });
    out.indices = std::move(order);
    for (std::size_t k = 0; k < out.indices.size(); ++k) out.ids[k] = GaussianId{s.ids[out.indices[k]]};
  }
  s.resident.clear();
  for (GaussianId id : out.ids) s.resident.set(id, 1);
  return out;
}

}  // namespace gauss
