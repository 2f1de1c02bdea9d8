// LodHierarchy: validation, leaf bookkeeping and the update's phases (leaves, sorted order,
// group trees, objects tree, root). The per-cell recursion is in lod_tree_build.cpp.
#include "gauss/engine/lod_hierarchy.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <string>

#include "gauss/engine/log_text.h"
#include "id_sort.h"
#include "lod_internal.h"
#include "lod_leaf_moments.h"

namespace gauss {

using lod_detail::kBackgroundTree;
using lod_detail::kGroupLevels;
using lod_detail::kObjectsLevels;
using lod_detail::kObjectsTree;
using lod_detail::kPendingLeaf;
using lod_detail::kRootTree;

Expected<LodHierarchy> LodHierarchy::create(int sh_degree, const LodConfig& config) {
  if (sh_degree < 0 || sh_degree > kMaxShDegree)
    return Error{"LodHierarchy: SH degree " + std::to_string(sh_degree) + " is outside 0..3"};
  if (config.max_leaves_per_node < 2 || config.max_leaves_per_node > 64)
    return Error{"LodHierarchy: max_leaves_per_node " + std::to_string(config.max_leaves_per_node) +
                 " is outside 2..64"};
  if (!(config.merge.max_scale > 0.0) || !std::isfinite(config.merge.max_scale))
    return Error{"LodHierarchy: merge.max_scale must be positive and finite"};
  if (!(config.merge.spread >= 1.0) || !std::isfinite(config.merge.spread))
    return Error{"LodHierarchy: merge.spread must be finite and at least 1"};
  const LodCube& c = config.cube;
  if (!(c.edge >= 0.0) || !std::isfinite(c.edge) || !std::isfinite(c.min.x) || !std::isfinite(c.min.y) ||
      !std::isfinite(c.min.z))
    return Error{"LodHierarchy: cube edge must be >= 0 and the cube finite (edge 0: fixed by the first epoch)"};
  LodHierarchy h;
  h.next_generation();
  h.config_ = config;
  if (c.edge > 0.0) {
    h.cube_min_ = c.min;
    h.cell_inv_ = double(1u << kGroupLevels) / c.edge;
    h.cube_set_ = true;
  }
  h.sh_degree_ = sh_degree;
  h.rest_count_ = sh_rest_count(sh_degree);
  return h;
}

Expected<LodHierarchy> LodHierarchy::build(std::span<const Gaussian> gaussians, int sh_degree,
                                           const LodConfig& config) {
  auto h = create(sh_degree, config);
  if (!h) return h.error();
  if (auto r = h->update(gaussians); !r) return Error{"LodHierarchy::build: " + r.message()};
  return std::move(h.value());
}

std::uint32_t LodHierarchy::find_leaf(GaussianId id) const {
  const std::uint32_t* v = leaf_index_.find(to_underlying(id));
  return v && *v != kPendingLeaf ? *v : kNoLodNode;
}

std::uint32_t LodHierarchy::object_root(ObjectId o) const {
  if (to_underlying(o) < 0) return kNoLodNode;
  const std::uint32_t tree = tree_of(o);
  auto it = std::lower_bound(group_roots_.begin(), group_roots_.end(), std::pair{tree, 0u});
  return it != group_roots_.end() && it->first == tree ? it->second : kNoLodNode;
}

Gaussian LodHierarchy::leaf_gaussian(const LodNode& n) const {
  const LeafFields& f = leaf_fields_[n.data];
  Gaussian g;
  g.position = f.position;
  g.log_scale = f.log_scale;
  g.rotation = f.rotation;
  g.opacity_logit = f.opacity_logit;
  g.sh_dc = f.sh_dc;
  const std::size_t rc = std::size_t(rest_count_);
  for (std::size_t k = 0; k < rc; ++k) g.sh_rest[k] = leaf_rest_[std::size_t(n.data) * rc + k];
  g.id = n.id;
  g.object = f.object;
  g.support = f.support;
  return g;
}

std::uint64_t LodHierarchy::morton(const glm::vec3& p) const {
  constexpr double kMax = double((1u << kGroupLevels) - 1);
  auto q = [&](int a) {
    const double v = std::floor((double(p[a]) - cube_min_[a]) * cell_inv_);
    return std::uint64_t(std::clamp(v, 0.0, kMax));
  };
  return lod_detail::morton3(q(0), q(1), q(2));
}

std::uint32_t LodHierarchy::tree_of(ObjectId o) const {
  return to_underlying(o) >= 0 ? std::uint32_t(to_underlying(o)) : kBackgroundTree;
}

std::uint32_t LodHierarchy::alloc_node() {
  if (!free_nodes_.empty()) {
    const std::uint32_t n = free_nodes_.back();
    free_nodes_.pop_back();
    nodes_[n] = LodNode{};
    return n;
  }
  nodes_.emplace_back();
  touch_stamp_.push_back(0);
  return std::uint32_t(nodes_.size() - 1);
}

void LodHierarchy::store_leaf(std::uint32_t node, const Gaussian& g) {
  LodNode& n = nodes_[node];
  leaf_fields_[n.data] = LeafFields{g.position, g.log_scale, g.rotation, g.opacity_logit, g.sh_dc, g.object, g.support};
  const std::size_t rc = std::size_t(rest_count_);
  for (std::size_t k = 0; k < rc; ++k) leaf_rest_[std::size_t(n.data) * rc + k] = g.sh_rest[k];
  n.id = g.id;
  n.centre = g.position;
  n.radius = 3.0f * std::exp(std::max({g.log_scale.x, g.log_scale.y, g.log_scale.z}));
  n.leaf_count = 1;
  n.height = 0;
  n.live = true;
  n.leaf = true;
}

bool LodHierarchy::same_leaf_value(std::uint32_t node, const Gaussian& g) const {
  const std::uint32_t slot = nodes_[node].data;
  const LeafFields& f = leaf_fields_[slot];
  const std::size_t rc = std::size_t(rest_count_);
  const glm::vec3* rest = leaf_rest_.data() + std::size_t(slot) * rc;
  // Equal bits are equal values: a stored leaf has no NaN (it was usable), so neither has g
  // where the bits agree. Only where they differ (a change, or +0 against -0) does it take
  // the field-by-field float comparison, which decides.
  static_assert(offsetof(LeafFields, position) == offsetof(Gaussian, position) &&
                offsetof(LeafFields, log_scale) == offsetof(Gaussian, log_scale) &&
                offsetof(LeafFields, rotation) == offsetof(Gaussian, rotation) &&
                offsetof(LeafFields, opacity_logit) == offsetof(Gaussian, opacity_logit) &&
                offsetof(LeafFields, sh_dc) == offsetof(Gaussian, sh_dc) && offsetof(LeafFields, sh_dc) + 12 == 56);
  if (std::memcmp(&f, &g, 56) == 0 && f.object == g.object && f.support == g.support &&
      (rc == 0 || std::memcmp(rest, g.sh_rest.data(), rc * sizeof(glm::vec3)) == 0))
    return true;
  if (!(f.position == g.position && f.log_scale == g.log_scale && f.rotation == g.rotation &&
        f.opacity_logit == g.opacity_logit && f.sh_dc == g.sh_dc && f.object == g.object && f.support == g.support))
    return false;
  for (std::size_t k = 0; k < rc; ++k)
    if (rest[k] != g.sh_rest[k]) return false;
  return true;
}

Expected<LodUpdateReport> LodHierarchy::update(std::span<const Gaussian> gaussians) {
  return update_from(gaussians.data(), gaussians.size(),
                     [&](std::size_t k) -> const Gaussian& { return gaussians[k]; });
}

Expected<LodUpdateReport> LodHierarchy::update(std::span<const Gaussian> gaussians,
                                               std::span<const std::uint32_t> subset) {
  for (std::uint32_t i : subset)
    if (i >= gaussians.size())
      return Error{"LodHierarchy::update: subset index " + std::to_string(i) + " outside the scene's " +
                   std::to_string(gaussians.size()) + " Gaussians"};
  return update_from(gaussians.data(), subset.size(),
                     [&](std::size_t k) -> const Gaussian& { return gaussians[subset[k]]; });
}

template <typename Get>
Expected<LodUpdateReport> LodHierarchy::update_from(const Gaussian* base, std::size_t count, Get&& get) {
  next_generation();  // leaf places change below even when nothing else does
  if (leaf_index_.size() == 0) {
    // Nothing to compare with: the full build (same tree, records, ids and report as the
    // general path below would give, without its per-leaf diffing; lod_full_build.cpp).
    // On huge pages, as the build's own scratch (lod_full_build.cpp): 8 MB at a million.
    detail::TableVector<const Gaussian*> all(count);
    for (std::size_t k = 0; k < count; ++k) all[k] = &get(k);
    return build_from_empty(all, base);
  }
  // Leaves not met below are the removed ones; a leaf met twice is a duplicate id.
  const std::uint32_t seen = next_stamp();
  std::vector<const Gaussian*> upserts;
  std::vector<std::uint32_t> upsert_places;  // k of each upsert
  std::size_t met = 0;                       // leaves met (each once, or the update fails)
  const std::size_t hinted = std::min(count, input_nodes_.size());
  input_nodes_.resize(count, kNoLodNode);
  constexpr std::size_t kBlock = 32;
  for (std::size_t k = 0; k < count; ++k) {
    if (k % kBlock == 0) {
      std::uint32_t acc = 0;
      for (std::size_t i = k; i < std::min(count, k + kBlock); ++i) {
        const Gaussian& gi = get(i);
        acc += std::uint32_t(to_underlying(gi.id)) + std::bit_cast<std::uint32_t>(gi.position.x);
      }
      lod_detail::keep(acc);
    }
    const Gaussian& g = get(k);
    // The leaf this place became last time, if it still is this id's leaf (ids are unique
    // among leaves, so a live leaf with the id is the one find_leaf would give); else by id.
    std::uint32_t node = k < hinted ? input_nodes_[k] : kNoLodNode;
    if (node >= nodes_.size() || !nodes_[node].live || !nodes_[node].leaf || nodes_[node].id != g.id)
      node = find_leaf(g.id);
    input_nodes_[k] = node;
    if (node == kNoLodNode) {
      upserts.push_back(&g);
      upsert_places.push_back(std::uint32_t(k));
      continue;
    }
    if (touch_stamp_[node] == seen) return Error{"LodHierarchy::update: Gaussian id " + id_text(g.id) + " appears twice"};
    touch_stamp_[node] = seen;
    ++met;
    if (!same_leaf_value(node, g)) {
      upserts.push_back(&g);
      upsert_places.push_back(std::uint32_t(k));
    } else {
      leaf_source_[nodes_[node].data] = static_cast<std::uint32_t>(&g - base);
    }
  }
  std::vector<GaussianId> removed;
  if (met != leaf_index_.size())  // some leaf was not met: find which (in the index's order)
    leaf_index_.for_each([&](std::uint64_t id, std::uint32_t node) {
      if (touch_stamp_[node] != seen) removed.push_back(GaussianId{id});
    });
  auto report = apply_changes(upserts, removed, false);
  if (!report) return report;
  // The changed leaves' places in the input (the unchanged ones were noted above), now that
  // new leaves have their slots; a Gaussian left out as unusable has none.
  for (std::size_t u = 0; u < upserts.size(); ++u) {
    const std::uint32_t node = find_leaf(upserts[u]->id);
    input_nodes_[upsert_places[u]] = node;
    if (node != kNoLodNode) leaf_source_[nodes_[node].data] = static_cast<std::uint32_t>(upserts[u] - base);
  }
  return report;
}

Expected<LodUpdateReport> LodHierarchy::apply(std::span<const Gaussian> upserts, std::span<const GaussianId> removed,
                                              bool lenient_removes) {
  std::vector<const Gaussian*> ptrs;
  ptrs.reserve(upserts.size());
  for (const Gaussian& g : upserts) ptrs.push_back(&g);
  return apply_changes(ptrs, removed, lenient_removes);
}

Expected<LodUpdateReport> LodHierarchy::apply_changes(std::span<const Gaussian* const> upserts,
                                                      std::span<const GaussianId> removed, bool lenient) {
  next_generation();
  // --- 1. Validate, changing nothing that cannot be rolled back. ---------------------------
  const std::uint32_t stamp = next_stamp();
  std::vector<std::uint64_t> pending;  // new ids marked in leaf_index_, erased on failure
  auto fail = [&](std::string message) -> Expected<LodUpdateReport> {
    for (std::uint64_t id : pending) leaf_index_.erase(id);
    return Error{std::move(message)};
  };
  // Each id is looked up once, here (its node kept for step 2), with the lookups a few ahead
  // asked of the cache first: at a million leaves the index is tens of megabytes, and a
  // trainer's snapshot changing every leaf spent a sixth of its update waiting on them.
  constexpr std::size_t kAhead = 16;
  std::vector<std::uint32_t> removed_nodes(removed.size());  // kNoLodNode: not a leaf (lenient)
  for (std::size_t i = 0; i < removed.size(); ++i) {
    if (i + kAhead < removed.size()) leaf_index_.prefetch(to_underlying(removed[i + kAhead]));
    const GaussianId id = removed[i];
    if (to_underlying(id) & kLodInteriorIdBit)
      return fail("LodHierarchy: removed id " + id_text(id) + " has the top bit set (reserved for interior nodes)");
    const std::uint32_t node = find_leaf(id);
    removed_nodes[i] = node;
    if (node == kNoLodNode) {
      if (lenient) continue;
      return fail("LodHierarchy: removed id " + id_text(id) + " is not a leaf");
    }
    if (touch_stamp_[node] == stamp) return fail("LodHierarchy: id " + id_text(id) + " is removed twice");
    touch_stamp_[node] = stamp;
  }
  std::vector<std::uint32_t> upsert_nodes(upserts.size());  // its leaf, or kPendingLeaf: new
  for (std::size_t i = 0; i < upserts.size(); ++i) {
    if (i + kAhead < upserts.size()) leaf_index_.prefetch(to_underlying(upserts[i + kAhead]->id));
    const Gaussian* g = upserts[i];
    const std::uint64_t id = to_underlying(g->id);
    if (id & kLodInteriorIdBit)
      return fail("LodHierarchy: Gaussian id " + id_text(g->id) + " has the top bit set (reserved for interior nodes)");
    const std::uint32_t* v = leaf_index_.find(id);
    if (v && *v == kPendingLeaf) return fail("LodHierarchy: Gaussian id " + id_text(g->id) + " is given twice");
    if (v) {
      if (touch_stamp_[*v] == stamp)
        return fail("LodHierarchy: Gaussian id " + id_text(g->id) + " is given twice (or also removed)");
      touch_stamp_[*v] = stamp;
      upsert_nodes[i] = *v;
    } else {
      leaf_index_.set(id, kPendingLeaf);
      pending.push_back(id);
      upsert_nodes[i] = kPendingLeaf;
    }
  }

  // --- 2. Leaves: classify, store, and note each change's old and new cells. ---------------
  LodUpdateReport report;
  std::vector<LodLeafStatus> status(upserts.size());
  for (std::size_t i = 0; i < upserts.size(); ++i) status[i] = lod_detail::leaf_status(*upserts[i], rest_count_, config_.merge);
  if (!cube_set_) {
    glm::dvec3 lo(std::numeric_limits<double>::max()), hi(std::numeric_limits<double>::lowest());
    for (std::size_t i = 0; i < upserts.size(); ++i)
      if (status[i] == LodLeafStatus::Usable) {
        lo = glm::min(lo, glm::dvec3(upserts[i]->position));
        hi = glm::max(hi, glm::dvec3(upserts[i]->position));
      }
    fix_cube(lo, hi);
  }

  std::vector<Entry> fresh;             // entries entering the order
  std::vector<Entry> leaving;           // entries leaving it (as they stand)
  std::vector<std::uint32_t> dead_leaves;  // nodes freed at the end
  std::vector<Entry> in_place;          // leaves changed within their cell
  // Room for the most each can get: a large change set (every leaf of a trainer's snapshot)
  // otherwise regrows them onto fresh pages a few times over; room never written is not taken.
  fresh.reserve(upserts.size());
  leaving.reserve(upserts.size() + removed.size());
  dead_leaves.reserve(upserts.size() + removed.size());
  in_place.reserve(upserts.size());
  auto remove_leaf = [&](std::uint32_t node) {
    const LeafFields& f = leaf_fields_[nodes_[node].data];
    const std::uint32_t tree = tree_of(f.object);
    const std::uint64_t code = morton(f.position);
    leaving.push_back(Entry{tree, node, code});
    dead_leaves.push_back(node);
    leaf_index_.erase(to_underlying(nodes_[node].id));
    ++report.leaves_removed;
  };
  for (std::uint32_t node : removed_nodes)
    if (node != kNoLodNode) remove_leaf(node);
  for (std::size_t i = 0; i < upserts.size(); ++i) {
    const Gaussian& g = *upserts[i];
    const std::uint32_t node = upsert_nodes[i];  // a leaf (not removed: validated) or pending
    if (status[i] != LodLeafStatus::Usable) {
      ++report.skipped;
      if (node == kPendingLeaf)
        leaf_index_.erase(to_underlying(g.id));
      else
        remove_leaf(node);  // a leaf turned unusable leaves the hierarchy
      continue;
    }
    const std::uint32_t tree = tree_of(g.object);
    const std::uint64_t code = morton(g.position);
    if (node == kPendingLeaf) {
      const std::uint32_t n = alloc_node();
      if (!free_leaf_slots_.empty()) {
        nodes_[n].data = free_leaf_slots_.back();
        free_leaf_slots_.pop_back();
        leaf_source_[nodes_[n].data] = kNoLodSource;
      } else {
        nodes_[n].data = std::uint32_t(leaf_fields_.size());
        leaf_fields_.emplace_back();
        leaf_source_.push_back(kNoLodSource);
        leaf_rest_.resize(leaf_rest_.size() + std::size_t(rest_count_));
      }
      store_leaf(n, g);
      leaf_index_.set(to_underlying(g.id), n);
      fresh.push_back(Entry{tree, n, code});
      ++report.leaves_inserted;
      continue;
    }
    if (same_leaf_value(node, g)) continue;  // apply() may pass unchanged Gaussians
    const LeafFields& f = leaf_fields_[nodes_[node].data];
    const std::uint32_t old_tree = tree_of(f.object);
    const std::uint64_t old_code = morton(f.position);
    if (old_tree != tree || old_code != code) {
      leaving.push_back(Entry{old_tree, node, old_code});
      fresh.push_back(Entry{tree, node, code});
    } else {
      in_place.push_back(Entry{tree, node, code});
    }
    store_leaf(node, g);
    ++report.leaves_modified;
  }
  if (leaving.empty() && fresh.empty()) {  // values only (a recolouring, say): no leaf changed cell
    if (in_place.empty()) return report;
    std::vector<std::uint32_t> changed;
    changed.reserve(in_place.size());
    for (const Entry& e : in_place) changed.push_back(e.node);
    remerge_ancestors(changed, report);
    sort_report(report);
    return report;
  }

  // --- 3. The sorted leaf order: drop leaving entries, merge fresh ones in. ----------------
  // (Some leaf enters, leaves or changes cell: the value-only case returned above.)
  sort_entries(leaving);
  sort_entries(fresh);
  sort_entries(in_place);
  update_order(leaving, fresh);

  // --- 4-5. Group trees with changes, the objects tree and the root. --------------------
  const auto dirty = changed_places(leaving, fresh, in_place);
  std::vector<std::uint32_t> retired;
  warm_descent(leaving);
  update_trees(dirty, fresh, leaving, report, retired, false);
  // --- 6. Free what left, compact the children runs, sort the report. --------------------
  for (std::uint32_t n : retired) {
    free_interior_slots_.push_back(nodes_[n].data);
    free_nodes_.push_back(n);
  }
  for (std::uint32_t n : dead_leaves) {
    nodes_[n].live = false;
    free_leaf_slots_.push_back(nodes_[n].data);
    free_nodes_.push_back(n);
  }
  if (children_garbage_ > 4096 && children_garbage_ * 2 > children_.size()) compact_children();
  sort_report(report);
  return report;
}

bool LodHierarchy::entry_less(const Entry& a, const Entry& b) const {
  // Entries hold no id (16 bytes, not 24: the order is copied whole each update); the rare
  // tie of tree and code reads the two nodes' ids.
  if (a.tree != b.tree) return a.tree < b.tree;
  if (a.code != b.code) return a.code < b.code;
  return nodes_[a.node].id < nodes_[b.node].id;
}

void LodHierarchy::sort_entries(std::span<Entry> list) const {
  auto less = [this](const Entry& a, const Entry& b) { return entry_less(a, b); };
  // Trees by a stable counting sort over their ranks, each tree's codes by radix passes over
  // the bits in which they differ, runs of equal codes (coincident leaves) by id: the order a
  // comparison sort gives. Comparison sorts of a large change set's lists (a trainer's
  // snapshot moves every leaf: a million entries entering the order, a million leaving and
  // two million changed places) were a quarter of its update, and a tenth of a full build. The scratch of tens of megabytes
  // (TableVector) lies on huge pages, as the pools do: on plain vectors it came fresh from
  // the kernel on 4 KiB pages wherever the heap had no such room, about 11k page faults a
  // build at a million leaves (LodHierarchy.Timing at SH 3).
  constexpr std::size_t kRadixFrom = 4096;
  if (list.size() < kRadixFrom) {
    std::sort(list.begin(), list.end(), less);
    return;
  }
  // The distinct trees in the order first seen (seen[i]: entry i's tree's place there), then
  // their ranks in tree order.
  detail::TableVector<std::uint32_t> seen(list.size());
  std::vector<std::uint32_t> trees;
  {
    detail::IdIndex place;
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::uint32_t* p = place.find(list[i].tree);
      if (!p) {
        place.set(list[i].tree, std::uint32_t(trees.size()));
        trees.push_back(list[i].tree);
        p = place.find(list[i].tree);
      }
      seen[i] = *p;
    }
  }
  std::vector<std::uint32_t> rank(trees.size());  // first-seen place -> rank in tree order
  {
    std::vector<std::uint32_t> by(trees.size());
    for (std::uint32_t i = 0; i < by.size(); ++i) by[i] = i;
    std::sort(by.begin(), by.end(), [&](std::uint32_t a, std::uint32_t b) { return trees[a] < trees[b]; });
    for (std::uint32_t r = 0; r < by.size(); ++r) rank[by[r]] = r;
  }
  std::vector<std::size_t> start(trees.size() + 1, 0);
  for (std::size_t i = 0; i < list.size(); ++i) ++start[rank[seen[i]] + 1];
  for (std::size_t r = 0; r < trees.size(); ++r) start[r + 1] += start[r];
  detail::TableVector<lod_detail::IdPair> pairs(list.size()), scratch;
  {
    std::vector<std::size_t> at(start.begin(), start.end() - 1);
    for (std::size_t i = 0; i < list.size(); ++i) pairs[at[rank[seen[i]]]++] = {list[i].code, list[i].node};
  }
  std::sort(trees.begin(), trees.end());
  for (std::size_t r = 0; r < trees.size(); ++r) {
    const auto run = std::span<lod_detail::IdPair>(pairs).subspan(start[r], start[r + 1] - start[r]);
    lod_detail::sort_by_id(run, scratch);
    for (std::size_t i = start[r]; i < start[r + 1]; ++i) list[i] = Entry{trees[r], pairs[i].second, pairs[i].first};
  }
  for (std::size_t i = 0; i < list.size();) {
    std::size_t e = i + 1;
    while (e < list.size() && list[e].tree == list[i].tree && list[e].code == list[i].code) ++e;
    if (e - i > 1) std::sort(list.begin() + std::ptrdiff_t(i), list.begin() + std::ptrdiff_t(e), less);
    i = e;
  }
}

std::vector<std::pair<std::uint32_t, std::uint64_t>> LodHierarchy::changed_places(std::span<const Entry> leaving,
                                                                                  std::span<const Entry> fresh,
                                                                                  std::span<const Entry> in_place) {
  // The three lists are sorted by (tree, code): merged, without repeats, in one pass.
  std::vector<std::pair<std::uint32_t, std::uint64_t>> places;
  places.reserve(leaving.size() + fresh.size() + in_place.size());
  std::size_t a = 0, b = 0, c = 0;
  auto key = [](const Entry& e) { return std::pair{e.tree, e.code}; };
  constexpr std::pair<std::uint32_t, std::uint64_t> kEnd{~std::uint32_t{0}, ~std::uint64_t{0}};
  while (a < leaving.size() || b < fresh.size() || c < in_place.size()) {
    const auto ka = a < leaving.size() ? key(leaving[a]) : kEnd;
    const auto kb = b < fresh.size() ? key(fresh[b]) : kEnd;
    const auto kc = c < in_place.size() ? key(in_place[c]) : kEnd;
    const auto least = std::min({ka, kb, kc});
    // kEnd is no place: no tree has the tag 2^32 - 1 (lod_internal.h).
    if (places.empty() || places.back() != least) places.push_back(least);
    a += ka == least && a < leaving.size();
    b += kb == least && b < fresh.size();
    c += kc == least && c < in_place.size();
  }
  return places;
}

void LodHierarchy::update_order(std::span<const Entry> leaving, std::span<const Entry> fresh) {
  // One pass: the runs between changes are copied whole, each run's end found by galloping
  // from its start, so the order is read and written once and no entry's node is looked at.
  auto less = [this](const Entry& a, const Entry& b) { return entry_less(a, b); };
  order_scratch_.resize(order_.size() - leaving.size() + fresh.size());
  const Entry* in = order_.data();
  const Entry* const end = in + order_.size();
  Entry* out = order_scratch_.data();
  std::size_t g = 0, f = 0;
  while (g < leaving.size() || f < fresh.size()) {
    const bool drop = f == fresh.size() || (g < leaving.size() && less(leaving[g], fresh[f]));
    const Entry& key = drop ? leaving[g] : fresh[f];
    const Entry* stop = lod_detail::gallop_partition_point(in, end, [&](const Entry& e) { return less(e, key); });
    out = std::copy(in, stop, out);
    in = stop;
    if (drop) {
      assert(in != end && in->node == key.node);  // a leaf's entry is its stored cell
      ++in;
      ++g;
    } else {
      *out++ = key;
      ++f;
    }
  }
  std::copy(in, end, out);
  order_.swap(order_scratch_);
}

void LodHierarchy::sort_report(LodUpdateReport& report) const {
  // Serials count up in creation order, so the added list is often sorted already.
  for (std::vector<GaussianId>* list : {&report.added, &report.removed, &report.modified})
    if (!std::is_sorted(list->begin(), list->end())) std::sort(list->begin(), list->end());
}

void LodHierarchy::update_trees(std::span<const std::pair<std::uint32_t, std::uint64_t>> dirty,
                                std::span<const Entry> fresh, std::span<const Entry> leaving, LodUpdateReport& report,
                                std::vector<std::uint32_t>& retired, bool all_new) {
  // --- 4. Group trees with changes. -----------------------------------------------------
  std::vector<std::uint64_t> codes;
  codes.reserve(dirty.size());
  for (const auto& d : dirty) codes.push_back(d.second);
  std::vector<std::uint32_t> stack;
  std::vector<LodMoments> scratch_moments;
  std::vector<glm::dvec3> scratch_rest;
  std::vector<DeferredMerge> deferred;
  auto make_build = [&](std::uint32_t tree, int levels) {
    TreeBuild b;
    b.tree = tree;
    b.levels = levels;
    b.report = &report;
    b.retired = &retired;
    b.stack = &stack;
    b.moments = &scratch_moments;
    b.rest = &scratch_rest;
    if (!all_new) b.deferred = &deferred;
    return b;
  };
  std::vector<std::uint64_t> changed_objects;
  bool background_changed = false;
  for (std::size_t i = 0; i < dirty.size();) {
    const std::uint32_t tree = dirty[i].first;
    std::size_t j = i;
    while (j < dirty.size() && dirty[j].first == tree) ++j;
    const auto first = std::partition_point(order_.begin(), order_.end(), [&](const Entry& e) { return e.tree < tree; });
    const auto last = std::partition_point(first, order_.end(), [&](const Entry& e) { return e.tree == tree; });
    const std::span<const Entry> items(order_.data() + (first - order_.begin()), std::size_t(last - first));
    auto root_it = std::lower_bound(group_roots_.begin(), group_roots_.end(), std::pair{tree, 0u},
                                    [](const auto& a, const auto& b) { return a.first < b.first; });
    const bool had = root_it != group_roots_.end() && root_it->first == tree;
    TreeBuild b = make_build(tree, kGroupLevels);
    b.full = all_new;
    b.sized = !all_new;
    auto of_tree = [&](std::span<const Entry> list) {
      const auto lo = std::partition_point(list.begin(), list.end(), [&](const Entry& e) { return e.tree < tree; });
      const auto hi = std::partition_point(lo, list.end(), [&](const Entry& e) { return e.tree == tree; });
      return list.subspan(std::size_t(lo - list.begin()), std::size_t(hi - lo));
    };
    const CellChanges changes{of_tree(fresh), of_tree(leaving), std::span<const std::uint64_t>(codes).subspan(i, j - i)};
    const std::uint32_t root = build_cell(b, items, 0, 0, had ? root_it->second : kNoLodNode, changes);
    flush_geometry(b);
    if (root == kNoLodNode) {
      if (had) group_roots_.erase(root_it);
    } else if (had) {
      root_it->second = root;
    } else {
      group_roots_.insert(root_it, {tree, root});
    }
    if (tree == kBackgroundTree)
      background_changed = true;
    else
      changed_objects.push_back(tree);
    i = j;
  }

  // --- 5. The objects tree (a radix tree over object ids) and the root. -------------------
  if (!changed_objects.empty()) {
    std::vector<Entry> items;
    for (const auto& [tree, node] : group_roots_)
      if (tree != kBackgroundTree) items.push_back(Entry{kObjectsTree, node, tree});
    TreeBuild b = make_build(kObjectsTree, kObjectsLevels);
    objects_root_ = build_cell(b, items, 0, 0, objects_root_, CellChanges{{}, {}, changed_objects});
    flush_geometry(b);
  }
  if (!changed_objects.empty() || background_changed) {
    const std::uint32_t background =
        !group_roots_.empty() && group_roots_.back().first == kBackgroundTree ? group_roots_.back().second : kNoLodNode;
    TreeBuild b = make_build(kRootTree, 0);
    const bool had_root_node = root_ != kNoLodNode && nodes_[root_].live && !nodes_[root_].leaf &&
                               keys_[nodes_[root_].data].tree == kRootTree;
    if (objects_root_ != kNoLodNode && background != kNoLodNode) {
      const std::uint32_t kids[2] = {objects_root_, background};
      root_ = make_interior(b, 0, 0, had_root_node ? root_ : kNoLodNode, kids, 0);
      flush_geometry(b);
    } else {
      if (had_root_node) retire_node(b, root_);
      root_ = objects_root_ != kNoLodNode ? objects_root_ : background;
    }
    if (root_ != kNoLodNode) nodes_[root_].parent = kNoLodNode;
  }
  if (!deferred.empty()) {
    TreeBuild b = make_build(kRootTree, 0);
    merge_in_batches(b, deferred);
  }
}

void LodHierarchy::fix_cube(const glm::dvec3& lo, const glm::dvec3& hi) {
  // The quantisation cube: 16x the first non-empty epoch's extent (at least 16 m) around its
  // centre, fixed from then on so codes, cells and ids stay comparable between epochs.
  if (cube_set_ || !(lo.x <= hi.x)) return;
  const glm::dvec3 e = hi - lo;
  const double half = 8.0 * std::max({e.x, e.y, e.z, 1.0});
  cube_min_ = 0.5 * (lo + hi) - half;
  cell_inv_ = double(1u << kGroupLevels) / (2.0 * half);
  cube_set_ = true;
}

std::size_t LodHierarchy::memory_bytes() const {
  auto bytes = [](const auto& v) { return v.capacity() * sizeof(typename std::decay_t<decltype(v)>::value_type); };
  return bytes(nodes_) + bytes(free_nodes_) + bytes(children_) + bytes(children_spare_) + bytes(leaf_fields_) +
         bytes(leaf_rest_) + bytes(leaf_source_) + bytes(input_nodes_) + bytes(free_leaf_slots_) +
         leaf_index_.bytes() + bytes(records_) + bytes(moments_) + bytes(keys_) + bytes(free_interior_slots_) +
         bytes(order_) + bytes(order_scratch_) + bytes(touch_stamp_) + bytes(group_roots_);
}

std::size_t LodHierarchy::bytes_for(std::size_t leaves, int sh_degree) {
  const std::size_t rc = std::size_t(sh_rest_count(std::clamp(sh_degree, 0, kMaxShDegree)));
  // A leaf: its node and stamp, fields and SH rest, source and input place, the id index's
  // cells (at most 4 per id: the table doubles past half full), two order entries and its
  // place in a children run (with garbage, and the compaction's spare buffer); while
  // building, the sort's scratch and pointers.
  const std::size_t leaf = sizeof(LodNode) + 4 + sizeof(LeafFields) + rc * sizeof(glm::vec3) + 4 + 4 +
                           4 * detail::IdIndex::kCellBytes + 2 * sizeof(Entry) + 16 + 60;
  // An interior node: its node and stamp, record, moments, key and place in a children run
  // (as a leaf's).
  const std::size_t interior = sizeof(LodNode) + 4 + sizeof(Gaussian) + sizeof(LodMoments) + sizeof(InteriorKey) + 16;
  return leaves * leaf + leaves / 2 * interior;
}

std::uint32_t LodHierarchy::next_stamp() {
  if (++stamp_ == 0) {  // wrapped: old marks could collide
    std::fill(touch_stamp_.begin(), touch_stamp_.end(), 0u);
    stamp_ = 1;
  }
  return stamp_;
}

void LodHierarchy::next_generation() {
  static std::atomic<std::uint64_t> counter{0};
  generation_ = counter.fetch_add(1, std::memory_order_relaxed) + 1;
}

void LodHierarchy::compact_children() {
  // Into the spare buffer, with room for as many runs again as stay live: the updates until
  // the next compaction (at garbage > half) then append without reallocating.
  const std::size_t live = children_.size() - children_garbage_;
  children_spare_.clear();
  children_spare_.reserve(2 * live + 4096);
  for (LodNode& n : nodes_) {
    if (!n.live || n.leaf) continue;
    const std::uint32_t first = std::uint32_t(children_spare_.size());
    children_spare_.insert(children_spare_.end(), children_.begin() + n.first_child,
                           children_.begin() + n.first_child + n.child_count);
    n.first_child = first;
  }
  children_.swap(children_spare_);
  children_garbage_ = 0;
}

}  // namespace gauss
