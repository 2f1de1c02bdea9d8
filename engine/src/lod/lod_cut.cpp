// LodCutter: greedy view-dependent refinement of a LodHierarchy under a node budget
// (lod_cut.h).
#include "gauss/engine/lod_cut.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>

namespace gauss {

namespace {

constexpr std::uint8_t kExcludedAll = 1;
constexpr std::uint8_t kExcludedMixed = 2;

// The selector's view terms (selector.h) for a bounding sphere, in double.
struct ViewError {
  glm::dmat3 head_from_world;
  glm::dvec3 eye;
  double tx, ty, inv_kx, inv_ky, inv_ramp, near, floor;

  ViewError(const ClientPose& pose, const SelectorConfig& c)
      : head_from_world(glm::transpose(glm::mat3_cast(glm::normalize(pose.orientation)))),
        eye(pose.position),
        tx(pose.tan_half_fov_x),
        ty(pose.tan_half_fov_y),
        inv_kx(1.0 / std::sqrt(1.0 + tx * tx)),
        inv_ky(1.0 / std::sqrt(1.0 + ty * ty)),
        inv_ramp(1.0 / std::sin(std::clamp(c.margin_deg, 0.1, 90.0) * std::numbers::pi / 180.0)),
        near(c.near_distance),
        floor(c.out_of_view_weight) {}

  // Angular radius times the facing factor; 0 for a non-finite sphere.
  double operator()(const glm::vec3& centre, float radius) const {
    const glm::dvec3 d = glm::dvec3(centre) - eye;
    const glm::dvec3 h = head_from_world * d;
    const double r = radius;
    const double dist = std::max(glm::length(d), near);
    // Distance of the sphere beyond the frustum's side planes, as a fraction of its distance.
    const double ex = (std::fabs(h.x) - tx * h.z) * inv_kx - r;
    const double ey = (std::fabs(h.y) - ty * h.z) * inv_ky - r;
    const double outside = std::max(ex, ey) / dist;
    const double facing = std::clamp(1.0 - (1.0 - floor) * outside * inv_ramp, floor, 1.0);
    const double e = r / dist * facing;
    return std::isfinite(e) ? e : 0.0;
  }
};

}  // namespace

LodCutter::LodCutter(SelectorConfig config) : config_(config) {}

void LodCutter::clear_previous() {
  for (std::uint32_t i : refined_list_) refined_id_[i] = 0;
  refined_list_.clear();
}

Expected<LodCut> LodCutter::cut(const LodHierarchy& h, const ClientPose& pose, std::size_t budget,
                                std::span<const ObjectId> excluded) {
  if (Status st = validate_client_pose(pose); !st) return st.error();
  if (Status st = validate_selector_config(config_); !st) return st.error();
  LodCut out;
  const std::size_t pool = h.nodes().size();
  refined_id_.resize(pool, 0);
  mark_stamp_.resize(pool, 0);
  mark_.resize(pool, 0);
  if (++stamp_ == 0) {
    std::fill(mark_stamp_.begin(), mark_stamp_.end(), 0u);
    stamp_ = 1;
  }
  auto mark_of = [&](std::uint32_t n) -> std::uint8_t { return mark_stamp_[n] == stamp_ ? mark_[n] : 0; };
  auto set_mark = [&](std::uint32_t n, std::uint8_t m) {
    mark_stamp_[n] = stamp_;
    mark_[n] = m;
  };
  // The excluded objects' subtrees, and every node above them (the mixed ones).
  for (ObjectId o : excluded) {
    const std::uint32_t r = h.object_root(o);
    if (r == kNoLodNode) continue;
    set_mark(r, kExcludedAll);
    for (std::uint32_t p = h.node(r).parent; p != kNoLodNode && mark_of(p) != kExcludedMixed; p = h.node(p).parent)
      set_mark(p, kExcludedMixed);
  }

  const ViewError error(pose, config_);
  const float bonus = static_cast<float>(1.0 + config_.retention_bonus);
  // Max-heap by error, then lower id.
  auto before = [](const Frontier& a, const Frontier& b) { return a.key < b.key || (a.key == b.key && a.id > b.id); };
  heap_.clear();
  std::size_t count = 0;  // nodes in the cut so far (heap + out.nodes)
  // Enters node n into the frontier; mixed nodes are refined at once (recursively: their
  // depth is the objects tree's, a few levels).
  auto enter = [&](auto&& self, std::uint32_t n) -> void {
    const std::uint8_t m = mark_of(n);
    if (m == kExcludedAll) return;
    const LodNode& node = h.node(n);
    if (m == kExcludedMixed) {
      for (std::uint32_t c : h.children(node)) self(self, c);
      return;
    }
    ++count;
    if (node.leaf) {
      out.nodes.push_back(n);
      ++out.leaves;
      return;
    }
    float key = static_cast<float>(error(node.centre, node.radius));
    if (refined_id_[n] == to_underlying(node.id)) key *= bonus;
    heap_.push_back(Frontier{key, to_underlying(node.id), n});
    std::push_heap(heap_.begin(), heap_.end(), before);
  };
  if (h.root() != kNoLodNode && budget > 0) enter(enter, h.root());

  if (count > budget) {
    // Forced refinement alone overflows B: keep the B nodes with the largest error.
    std::vector<Frontier> all(heap_.begin(), heap_.end());
    for (std::uint32_t n : out.nodes) {
      const LodNode& node = h.node(n);
      all.push_back(Frontier{static_cast<float>(error(node.centre, node.radius)), to_underlying(node.id), n});
    }
    std::sort(all.begin(), all.end(), [&](const Frontier& a, const Frontier& b) { return before(b, a); });
    all.resize(budget);
    heap_.clear();
    out.nodes.clear();
    out.leaves = 0;
    for (const Frontier& f : all) {
      if (h.node(f.node).leaf) {
        out.nodes.push_back(f.node);  // leaves go straight into the cut
        ++out.leaves;
      } else {
        heap_.push_back(f);  // interior ones wait, unrefined: the budget is full
      }
    }
    count = budget;
  }

  refined_next_.clear();
  while (!heap_.empty()) {
    if (count >= budget) {  // nothing more can refine: the rest stays as it is
      for (const Frontier& f : heap_) out.nodes.push_back(f.node);
      heap_.clear();
      break;
    }
    std::pop_heap(heap_.begin(), heap_.end(), before);
    const Frontier top = heap_.back();
    heap_.pop_back();
    const LodNode& node = h.node(top.node);
    if (count - 1 + node.child_count > budget) {
      out.nodes.push_back(top.node);
      continue;
    }
    --count;
    refined_next_.push_back(top.node);
    out.retained += refined_id_[top.node] == to_underlying(node.id);
    const auto children = h.children(node);
    if (node.height == 1) {
      // Its children are leaves, and unmarked (a mark reaches every ancestor, and this node
      // has none): into the cut without reading them, a cache miss each in a large pool.
      out.nodes.insert(out.nodes.end(), children.begin(), children.end());
      out.leaves += children.size();
      count += children.size();
      continue;
    }
    for (std::uint32_t c : children) enter(enter, c);
  }

  // This cut's refinements are the next call's hysteresis state.
  clear_previous();
  for (std::uint32_t n : refined_next_) refined_id_[n] = to_underlying(h.node(n).id);
  refined_list_.swap(refined_next_);
  out.refined = refined_list_.size();
  out.interior = out.nodes.size() - out.leaves;
  return out;
}

}  // namespace gauss
