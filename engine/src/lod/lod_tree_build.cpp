// The canonical tree of one group (or of the objects): the recursion that rebuilds only cells
// with changes and reuses every other subtree of the previous update untouched.
#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <type_traits>

#include "lod_internal.h"
#include "lod_leaf_moments.h"

namespace gauss {

using lod_detail::kRootTree;
using lod_detail::kSizedFrom;
using lod_detail::kWarmLeaves;

// Candidates: the previous update's node holding exactly the old leaves of the cell being
// built (see build_cell). Only interior nodes of the tree being built qualify: leaves are
// found from the items, and another tree's nodes (group roots under the objects tree) are
// that tree's business.
namespace {
bool candidate_of(std::span<const LodNode> nodes, std::uint32_t n) {
  return n != kNoLodNode && n < nodes.size() && nodes[n].live && !nodes[n].leaf;
}

// Adds a byte of every cache line of [p, p + bytes), bytes > 0, to `acc`: loads issued back
// to back, so that their misses overlap (see warm_leaves).
void touch_lines(const void* p, std::size_t bytes, std::uint32_t& acc) {
  const auto* c = static_cast<const unsigned char*>(p);
  for (std::size_t at = 0; at < bytes; at += 64) acc += c[at];
  acc += c[bytes - 1];
}

// The code of an order entry or of a changed leaf's place (CellChanges::dirty).
template <class E>
std::uint64_t code_of(const E& e) {
  if constexpr (std::is_same_v<E, std::uint64_t>)
    return e;
  else
    return e.code;
}
}  // namespace

std::uint32_t LodHierarchy::build_cell(TreeBuild& b, std::span<const Entry> items, int level,
                                       std::uint64_t prefix, std::uint32_t candidate, const CellChanges& changes) {
  // `candidate` (or none) holds exactly the cell's leaves as they were before this update:
  // the old tree's node for the cell (or the leaf, or another tree's root, where the cell
  // held one), or the deeper node a chain collapsed onto.
  // Nothing changed in the cell: the old subtree is the canonical one (returned unread).
  if (candidate != kNoLodNode && changes.dirty.empty()) return candidate;
  if (!candidate_of(nodes_, candidate) || keys_[nodes_[candidate].data].tree != b.tree) candidate = kNoLodNode;

  const std::size_t n = items.size();
  if (n == 0) {
    retire_subtree(b, candidate);
    return kNoLodNode;
  }
  if (n == 1) {
    retire_subtree(b, candidate);
    return items[0].node;
  }
  if (b.full && n <= kWarmLeaves && (!b.warmed_to || items.data() + n > b.warmed_to)) {
    warm_leaves(items);
    b.warmed_to = items.data() + n;
  }
  const bool here = candidate != kNoLodNode && keys_[nodes_[candidate].data].level == level &&
                    keys_[nodes_[candidate].data].prefix == prefix;

  if (n <= config_.max_leaves_per_node || level == b.levels) {
    // Bottom node: the leaves themselves are the children.
    if (here) {
      const LodNode& c = nodes_[candidate];
      if (keys_[c.data].octants != 0)  // it was split: its interior children go
        for (std::uint32_t kid : std::span<const std::uint32_t>(children_).subspan(c.first_child, c.child_count))
          retire_subtree(b, kid);
    } else {
      retire_subtree(b, candidate);
    }
    const std::size_t base = b.stack->size();
    for (const Entry& e : items) b.stack->push_back(e.node);
    const std::uint32_t made = make_interior(b, level, prefix, here ? candidate : kNoLodNode,
                                             std::span<const std::uint32_t>(*b.stack).subspan(base), 0);
    b.stack->resize(base);
    return made;
  }

  // The old subtree's pieces, by octant.
  std::array<std::uint32_t, 8> cands;
  cands.fill(kNoLodNode);
  auto octant_of = [&](std::uint32_t node) {
    const InteriorKey& k = keys_[nodes_[node].data];
    return std::size_t((k.prefix >> (3 * (k.level - (level + 1)))) & 7u);
  };
  bool old_known = false;  // cands stand for every octant's old leaves
  if (here) {
    // The old children by octant, from the node's octant mask (a node that was not split,
    // mask 0, has no child standing for an octant).
    const LodNode& c = nodes_[candidate];
    const std::uint8_t mask = keys_[c.data].octants;
    for (std::uint32_t d = 0, i = 0; d < 8; ++d)
      if (mask & (1u << d)) cands[d] = children_[c.first_child + i++];
    old_known = mask != 0;
  } else if (candidate != kNoLodNode) {
    cands[octant_of(candidate)] = candidate;  // a collapsed chain: it lies within one octant
    old_known = true;
  }

  // Split into octants (digits of the next level; items are sorted by code, so each octant is
  // a contiguous run), the changes too.
  const int shift = 3 * (b.levels - level - 1);
  auto split = [&]<class E>(std::span<const E> list, std::array<std::span<const E>, 8>& out, bool gallop) {
    std::size_t begin = 0;
    for (std::uint64_t d = 0; d < 8; ++d) {
      const std::uint64_t limit = ((prefix << 3) | d) + 1;
      auto below = [&](const E& e) { return (code_of(e) >> shift) < limit; };
      const auto from = list.begin() + std::ptrdiff_t(begin);
      // The last octant takes the rest: every entry lies in the cell.
      const std::size_t end =
          d == 7 ? list.size()
                 : std::size_t((gallop ? lod_detail::gallop_partition_point(from, list.end(), below)
                                       : std::find_if_not(from, list.end(), below)) -
                               list.begin());
      out[d] = list.subspan(begin, end - begin);
      begin = end;
    }
  };
  std::array<std::span<const Entry>, 8> parts, fresh8, leaving8;
  std::array<std::span<const std::uint64_t>, 8> dirty8;
  if (b.sized) {  // only a group tree's update carries its changes down
    split(changes.fresh, fresh8, false);
    split(changes.leaving, leaving8, false);
  }
  split(changes.dirty, dirty8, false);
  bool sized = false;
  if (b.sized && old_known && n > kSizedFrom) {
    // Each octant's size is its old leaf count (the old child's, read in parallel) plus what
    // enters it less what leaves it: a large cell's octant ends were searched for in the
    // sorted order by probes each waiting for the last (most of an update's descent at the
    // upper levels). Any mismatch (none is expected) falls back to the search.
    std::array<std::int64_t, 8> size{};
    for (std::size_t d = 0; d < 8; ++d)
      if (cands[d] != kNoLodNode) size[d] = nodes_[cands[d]].leaf_count;
    std::int64_t total = 0;
    bool fits = true;
    for (std::size_t d = 0; d < 8; ++d) {
      size[d] += std::int64_t(fresh8[d].size()) - std::int64_t(leaving8[d].size());
      fits = fits && size[d] >= 0;
      total += size[d];
    }
    assert(fits && total == std::int64_t(n));  // the candidate holds the cell's old leaves
    if (fits && total == std::int64_t(n)) {
      std::size_t begin = 0;
      for (std::size_t d = 0; d < 8; ++d) {
        parts[d] = items.subspan(begin, std::size_t(size[d]));
        begin += std::size_t(size[d]);
      }
      sized = true;
    }
  }
  // Each octant's end by galloping from its start (octants are small, and a binary search
  // over everything left would begin with probes far away).
  if (!sized) split(items, parts, true);

  int non_empty = 0;
  std::size_t only = 0;
  for (std::size_t d = 0; d < 8; ++d)
    if (!parts[d].empty()) {
      ++non_empty;
      only = d;
    }
  if (non_empty == 1) {
    // One octant holds everything: this cell is no node; the chain collapses onto the octant.
    for (std::size_t d = 0; d < 8; ++d)
      if (d != only) retire_subtree(b, cands[d]);
    if (here) retire_node(b, candidate);
    return build_cell(b, parts[only], level + 1, (prefix << 3) | only, cands[only],
                      CellChanges{fresh8[only], leaving8[only], dirty8[only]});
  }
  const std::size_t base = b.stack->size();
  std::uint8_t octants = 0;
  for (std::size_t d = 0; d < 8; ++d) {
    if (parts[d].empty()) {
      retire_subtree(b, cands[d]);
      continue;
    }
    const std::uint32_t child =
        build_cell(b, parts[d], level + 1, (prefix << 3) | d, cands[d], CellChanges{fresh8[d], leaving8[d], dirty8[d]});
    b.stack->push_back(child);
    octants = std::uint8_t(octants | (1u << d));
  }
  const std::uint32_t made = make_interior(b, level, prefix, here ? candidate : kNoLodNode,
                                           std::span<const std::uint32_t>(*b.stack).subspan(base), octants);
  b.stack->resize(base);
  return made;
}

void LodHierarchy::warm_leaves(std::span<const Entry> items) const {
  // A full build reads every leaf once, in the sorted order, while leaves lie in the pools in
  // input order: each would cost a miss on its node and one on its fields, one after another,
  // since the merges between them leave the core too little to overlap. Loads issued back to
  // back overlap: a few thousand leaves arrive in the time of a few misses and stay in L2
  // while the merges under the cell read them. (Loads, not prefetch hints: on the 2-core
  // VM the hints changed nothing, these took 0.2 s off a 1M build.)
  std::uint32_t acc = 0;
  for (const Entry& e : items) acc += nodes_[e.node].data;
  const std::size_t rc = std::size_t(rest_count_);
  for (const Entry& e : items) {
    const std::uint32_t slot = nodes_[e.node].data;
    acc += leaf_fields_[slot].support;
    if (rc > 0) touch_lines(leaf_rest_.data() + std::size_t(slot) * rc, rc * sizeof(glm::vec3), acc);
  }
  lod_detail::keep(acc);
}

void LodHierarchy::warm_merges(std::span<const std::uint32_t> nodes) const {
  // What the merges of `nodes` read, a stage at a time: each stage's addresses come from the
  // one before (the node's children run, the children's nodes, their fields or moments), and
  // within a stage the loads are independent, so their misses overlap across the batch.
  // Node by node, each node's chain of three misses came one after another (a recolouring:
  // 28.6 -> 25.5 ms at 1M).
  std::uint32_t acc = 0;
  for (std::uint32_t n : nodes) {
    const LodNode& w = nodes_[n];
    touch_lines(children_.data() + w.first_child, w.child_count * sizeof(std::uint32_t), acc);
    touch_lines(&moments_[w.data], sizeof(LodMoments), acc);
    touch_lines(&records_[w.data], sizeof(Gaussian), acc);
  }
  for (std::uint32_t n : nodes) {
    const LodNode& w = nodes_[n];
    for (std::uint32_t i = 0; i < w.child_count; ++i) acc += nodes_[children_[w.first_child + i]].data;
  }
  const std::size_t rc = std::size_t(rest_count_);
  for (std::uint32_t n : nodes) {
    const LodNode& w = nodes_[n];
    for (std::uint32_t i = 0; i < w.child_count; ++i) {
      const LodNode& k = nodes_[children_[w.first_child + i]];
      if (!k.leaf) {
        touch_lines(&moments_[k.data], sizeof(LodMoments), acc);
        if (rc > 0) touch_lines(records_[k.data].sh_rest.data(), std::size_t(rc) * sizeof(glm::vec3), acc);
        continue;
      }
      acc += leaf_fields_[k.data].support;
      if (rc > 0) touch_lines(leaf_rest_.data() + std::size_t(k.data) * rc, rc * sizeof(glm::vec3), acc);
    }
  }
  lod_detail::keep(acc);
}

template <class Visit>
void LodHierarchy::for_each_ancestor(std::vector<std::uint32_t> level, Visit&& visit) {
  // Up a level at a time over all the nodes at once: each step's parent loads are independent
  // of each other and overlap (a walk up one path at a time waits for each node before it can
  // ask for the next).
  const std::uint32_t stamp = next_stamp();
  std::vector<std::uint32_t> next;
  while (!level.empty()) {
    next.clear();
    for (std::uint32_t n : level) {
      const std::uint32_t p = nodes_[n].parent;
      if (p == kNoLodNode || touch_stamp_[p] == stamp) continue;
      touch_stamp_[p] = stamp;
      next.push_back(p);
    }
    for (std::uint32_t p : next) visit(p);
    level.swap(next);
  }
}

void LodHierarchy::warm_descent(std::span<const Entry> leaving) {
  // The descent from a root to each change reads, level by level, a node, its key and its
  // children run, each load waiting for the one before. The leaving leaves' old paths are
  // most of those nodes: walked up from the leaves a level at a time, every level's loads are
  // independent of each other and overlap, and the descent then finds them in cache.
  std::vector<std::uint32_t> leaves;
  leaves.reserve(leaving.size());
  for (const Entry& e : leaving) leaves.push_back(e.node);
  std::uint32_t acc = 0;
  for_each_ancestor(std::move(leaves), [&](std::uint32_t p) {
    const LodNode& w = nodes_[p];
    acc += keys_[w.data].level + children_[w.first_child];
  });
  lod_detail::keep(acc);
}

void LodHierarchy::node_moments(std::uint32_t node, LodMoments& m, std::span<glm::dvec3> rest) const {
  const LodNode& n = nodes_[node];
  if (!n.leaf) {
    // Its SH rest as its record holds it (floats): the record is what a parent's appearance
    // averages, in a full build and in an update alike.
    m = moments_[n.data];
    const Gaussian& r = records_[n.data];
    for (int k = 0; k < rest_count_; ++k) rest[std::size_t(k)] = glm::dvec3(r.sh_rest[std::size_t(k)]);
    return;
  }
  leaf_slot_moments(n.data, m, rest.data());
}

void LodHierarchy::leaf_slot_moments(std::uint32_t slot, LodMoments& m, glm::dvec3* rest) const {
  // Leaves were usable when stored, so this is Usable again (same fields, same config), and
  // bit for bit what leaf_moments(leaf_gaussian(n)) gives.
  const LeafFields& f = leaf_fields_[slot];
  const lod_detail::LeafFieldRefs leaf{f.position, f.log_scale, f.rotation, f.opacity_logit, f.sh_dc,
                                       leaf_rest_.data() + std::size_t(slot) * std::size_t(rest_count_),
                                       f.object, f.support};
  lod_detail::leaf_moments_of(leaf, rest_count_, config_.merge, &m, rest);
}

std::uint32_t LodHierarchy::make_interior(TreeBuild& b, int level, std::uint64_t prefix, std::uint32_t reuse,
                                          std::span<const std::uint32_t> kids, std::uint8_t octants) {
  std::uint32_t node = reuse;
  if (node != kNoLodNode) {
    children_garbage_ += nodes_[node].child_count;
  } else {
    node = alloc_node();
    std::uint32_t slot;
    if (!free_interior_slots_.empty()) {
      slot = free_interior_slots_.back();
      free_interior_slots_.pop_back();
    } else {
      slot = std::uint32_t(records_.size());
      records_.emplace_back();
      moments_.emplace_back();
      keys_.emplace_back();
    }
    keys_[slot] = InteriorKey{b.tree, std::uint8_t(level), 0, prefix};
    nodes_[node].id = GaussianId{kLodInteriorIdBit | next_serial_++};
    nodes_[node].data = slot;
    nodes_[node].parent = kNoLodNode;
    ++interior_live_;
    b.report->added.push_back(nodes_[node].id);
  }

  keys_[nodes_[node].data].octants = octants;
  if (b.deferred) {
    // Merged after the shapes stand (merge_in_batches): the descent then reads only keys,
    // nodes and children runs, and the merges' reads are loaded a batch at a time.
    nodes_[node].live = true;
    nodes_[node].leaf = false;
    b.deferred->push_back(DeferredMerge{node, reuse != kNoLodNode});
  } else {
    merge_kids(b, node, reuse != kNoLodNode, kids);
  }
  LodNode& n = nodes_[node];
  n.first_child = std::uint32_t(children_.size());
  n.child_count = std::uint32_t(kids.size());
  children_.insert(children_.end(), kids.begin(), kids.end());
  for (std::uint32_t kid : kids) nodes_[kid].parent = node;
  return node;
}

void LodHierarchy::merge_in_batches(TreeBuild& b, std::span<const DeferredMerge> list) {
  // In list order (children before parents). The reads of a batch's merges are loaded first,
  // a stage at a time (warm_merges), so their misses overlap across the batch: one node at a
  // time, each node's chain of misses (its children run, their nodes, their fields) was most
  // of an update's merge time.
  constexpr std::size_t kBatch = 16;
  for (std::size_t k = 0; k < list.size(); ++k) {
    if (k % kBatch == 0) {
      std::uint32_t batch[kBatch];
      const std::size_t m = std::min(list.size() - k, kBatch);
      for (std::size_t j = 0; j < m; ++j) batch[j] = list[k + j].node;
      warm_merges(std::span<const std::uint32_t>(batch, m));
    }
    const LodNode& n = nodes_[list[k].node];
    merge_kids(b, list[k].node, list[k].kept,
               std::span<const std::uint32_t>(children_).subspan(n.first_child, n.child_count));
  }
  flush_geometry(b);
}

void LodHierarchy::merge_kids(TreeBuild& b, std::uint32_t node, bool kept, std::span<const std::uint32_t> kids) {
  const std::uint32_t slot = nodes_[node].data;
  // Moments of the children, then of the node (an update's callers have loaded what this
  // reads: merge_in_batches; a full build's leaves are warm_leaves').
  const std::size_t rc = std::size_t(rest_count_);
  b.moments->resize(kids.size());
  b.rest->resize(kids.size() * rc + 1);
  std::uint32_t leaves = 0;
  std::uint16_t height = 0;
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(std::numeric_limits<float>::lowest());
  for (std::size_t i = 0; i < kids.size(); ++i) {
    const LodNode& k = nodes_[kids[i]];
    node_moments(kids[i], (*b.moments)[i], std::span<glm::dvec3>(*b.rest).subspan(i * rc, rc + 1));
    leaves += k.leaf_count;
    height = std::max<std::uint16_t>(height, k.height);
    lo = glm::min(lo, k.centre - k.radius);
    hi = glm::max(hi, k.centre + k.radius);
  }
  const LodMoments before = moments_[slot];
  std::array<glm::dvec3, kMaxShRest> rest_moments;
  const auto rest = std::span<glm::dvec3>(rest_moments).first(rc);
  combine_moments(*b.moments, *b.rest, rest_count_, moments_[slot], rest);
  // The record's appearance now (its parent's merge reads its SH rest), its geometry now only
  // for a recolouring (the eigen decomposition would give what it gave), else with the next
  // kSymEigen3Lanes - 1 merges' (flush_geometry).
  Gaussian& record = records_[slot];
  Gaussian looks = record;  // a kept node's record as it was
  moments_appearance(moments_[slot], rest, rest_count_, looks);
  looks.id = nodes_[node].id;
  const bool appearance_changed = kept && !same_value(record, looks);
  record = looks;
  if (kept && same_geometry(before, moments_[slot])) {
    if (appearance_changed) b.report->modified.push_back(looks.id);
  } else {
    b.pending[b.pending_count++] = TreeBuild::PendingGeometry{node, kept, appearance_changed};
    if (b.pending_count == b.pending.size()) flush_geometry(b);
  }
  ++b.report->nodes_merged;
  b.report->inputs_merged += kids.size();

  // The bounding sphere around the children's spheres (centre: their box's centre).
  const glm::vec3 centre = 0.5f * (lo + hi);
  float radius = 0.0f;
  for (std::uint32_t kid : kids) {
    const LodNode& k = nodes_[kid];
    radius = std::max(radius, glm::length(k.centre - centre) + k.radius);
  }

  LodNode& n = nodes_[node];
  n.leaf_count = leaves;
  n.centre = centre;
  n.radius = radius;
  n.height = std::uint16_t(height + 1);
  n.live = true;
  n.leaf = false;
}

void LodHierarchy::flush_geometry(TreeBuild& b) {
  const std::size_t count = b.pending_count;
  if (count == 0) return;
  std::array<glm::dmat3, kSymEigen3Lanes> covariance;
  std::array<SymEigen3, kSymEigen3Lanes> eigen;
  for (std::size_t i = 0; i < count; ++i)
    covariance[i] = moments_covariance(moments_[nodes_[b.pending[i].node].data], config_.merge.spread);
  sym_eigen3_lanes(std::span<const glm::dmat3>(covariance).first(count), eigen);
  for (std::size_t i = 0; i < count; ++i) {
    const TreeBuild::PendingGeometry& p = b.pending[i];
    const std::uint32_t slot = nodes_[p.node].data;
    Gaussian& record = records_[slot];
    Gaussian shaped = record;  // its appearance is written; its geometry, if kept, the old one
    moments_geometry(moments_[slot], eigen[i], shaped);
    if (p.kept && (p.appearance_changed || !same_value(record, shaped))) b.report->modified.push_back(shaped.id);
    record = shaped;
  }
  b.pending_count = 0;
}

void LodHierarchy::remerge_ancestors(std::span<const std::uint32_t> changed, LodUpdateReport& report) {
  // Every interior node above a changed leaf, once, children before parents (a node is
  // higher than each of its children).
  std::vector<std::uint64_t> above;  // height << 32 | node: sorted without reading the nodes again
  for_each_ancestor(std::vector<std::uint32_t>(changed.begin(), changed.end()),
                    [&](std::uint32_t p) { above.push_back(std::uint64_t{nodes_[p].height} << 32 | p); });
  std::sort(above.begin(), above.end());
  std::vector<DeferredMerge> list;
  list.reserve(above.size());
  for (std::uint64_t a : above) list.push_back(DeferredMerge{std::uint32_t(a), true});
  std::vector<LodMoments> scratch_moments;
  std::vector<glm::dvec3> scratch_rest;
  TreeBuild b;
  b.report = &report;
  b.moments = &scratch_moments;
  b.rest = &scratch_rest;
  merge_in_batches(b, list);
}

void LodHierarchy::retire_node(TreeBuild& b, std::uint32_t node) {
  LodNode& n = nodes_[node];
  n.live = false;
  children_garbage_ += n.child_count;
  --interior_live_;
  b.report->removed.push_back(n.id);
  b.retired->push_back(node);
}

void LodHierarchy::retire_subtree(TreeBuild& b, std::uint32_t node) {
  if (!candidate_of(nodes_, node) || keys_[nodes_[node].data].tree != b.tree) return;
  const LodNode& n = nodes_[node];
  if (keys_[n.data].octants != 0)  // else its children are leaves (or other trees' roots)
    for (std::uint32_t i = 0; i < n.child_count; ++i) retire_subtree(b, children_[n.first_child + i]);
  retire_node(b, node);
}

}  // namespace gauss
