#pragma once
// LodHierarchy: a merge hierarchy over one epoch's eligible Gaussians, kept up to date
// incrementally, from which the host can cut a level of detail under the budget M.
//
// Shape. Leaves are the scene's Gaussians (their ids and values). Leaves are grouped by object
// first: each semantic object gets its own subtree, the unlabelled Gaussians (object < 0) one
// background subtree; the object subtrees hang under a radix tree over object ids (fan-out <= 8),
// and the root has that and the background subtree as children (either alone is the root).
// Within a group the subtree is an adaptive octree over the leaves' Morton codes (21 bits per
// axis in a fixed cube, LodConfig::cube):
//   - a cell holding at most LodConfig::max_leaves_per_node leaves is one node whose children
//     are those leaves (a "bottom" node; at the finest level, 2^-21 of the cube, a cell holds
//     any number: coincident leaves cannot be split);
//   - a larger cell is split into its non-empty octants (fan-out 2..8);
//   - a cell with a single non-empty octant is no node of its own (the chain collapses onto the
//     first cell that splits), and a cell with a single leaf is that leaf.
// The tree is thus a pure function of the leaf set and the cube: an incremental update
// and a full build of the same leaves give the same nodes and bit-identical records.
//
// Ids. Interior nodes have ids with the top bit set (kLodInteriorIdBit | serial, serials never
// reused), which no scene Gaussian has: SceneStore and the trackers hand out ids counting up
// from 0, and a Gaussian id with the top bit is refused. An interior node is its cell (tree,
// octree level, Morton prefix), and keeps its id as long as that cell is a node: while its leaf
// set is unchanged it is untouched, id and record (bit for bit); when leaves under it change
// it keeps its id and its record is recomputed (reported modified when the bits differ); when
// the cell stops being a node (emptied, or collapsed into a chain) the id is retired for good.
//
// Records. An interior node's record is the moment match of ALL leaves under it (lod_merge.h:
// weights opacity x area, law of total variance, optical depth conserved so opacity <= 1).
// Leaves that cannot enter a merge (non-finite fields, zero opacity x area, scale above
// LodConfig::merge.max_scale) are not leaves of the hierarchy: they are skipped, counted in the
// update report, and left for leaf-level selection; so every node stands for >= 1 usable leaf
// and every record is finite.
//
// Incremental cost. An update touches only the cells on the paths from changed leaves (old and
// new positions) to the root: O(changes x depth) node merges, plus O(N) sequential work to keep
// the sorted leaf order when leaves come or go (a merge of two sorted arrays); update() also
// compares every Gaussian with its stored leaf (O(N): first against the leaf its place in the
// last update()'s input became, then by id); apply() takes the changes as given. update() of an
// empty hierarchy is the full build, with no diffing: one pass over the input, a radix sort of
// the leaves, every cell merged once (the same tree, ids and records as the general path).
//
// Storage is flat: nodes in one pool (indices stable while a node lives; retired entries are
// reused by later updates, so walk from root(), never over the pool), children as runs in one
// index array, interior records in one array. Not thread-safe; one writer.
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/id_index.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/lod_merge.h"
#include "gauss/engine/result.h"

namespace gauss {

// Interior node ids: this bit set, the low 63 bits a serial. Leaf ids never carry it.
inline constexpr std::uint64_t kLodInteriorIdBit = std::uint64_t{1} << 63;
inline constexpr std::uint32_t kNoLodNode = 0xFFFFFFFFu;
inline constexpr std::uint32_t kNoLodSource = 0xFFFFFFFFu;

inline bool is_lod_interior_id(GaussianId id) { return (to_underlying(id) & kLodInteriorIdBit) != 0; }

// The cube the Morton codes quantise (21 bits per axis). The tree is canonical for a given
// cube: two hierarchies over the same leaves and cube are the same tree.
struct LodCube {
  glm::dvec3 min{0.0};
  double edge{0.0};  // metres, > 0
};

struct LodConfig {
  // A cell with more leaves than this is split. 8 matches the octree's fan-out: a bottom node
  // merges at most as many children as a split one. A random 1M-leaf scene gets 0.35 interior
  // nodes per leaf (cells are uneven: many bottom nodes hold 2 or 3 leaves). Range 2..64.
  std::uint32_t max_leaves_per_node{8};
  LodMergeConfig merge;
  // The quantisation cube; when absent (edge 0) it is fixed at the first non-empty update:
  // 16x that epoch's extent (at least 16 m) around its centre, so a scene growing after its
  // first epoch still falls inside. A caller that knows its scene's box (the codec's) may fix
  // it here; positions outside are clamped to the border cells (valid, only less split).
  LodCube cube;
  // Memory the hierarchy may take (its pools, the build's scratch and the copy a background
  // update reads), in bytes; 0: what the process can still have when an update starts
  // (memory_headroom(): MemAvailable, a cgroup's limit, ulimit -v). An update that would need
  // more is refused before anything is allocated (LodEpochHierarchy; its readers select
  // leaves meanwhile).
  std::size_t max_bytes{0};
};

struct LodNode {
  GaussianId id{0};                // leaf: the Gaussian's id; interior: kLodInteriorIdBit | serial
  std::uint32_t parent{kNoLodNode};
  std::uint32_t first_child{0};    // children: LodHierarchy::children()[first_child, +child_count)
  std::uint32_t child_count{0};    // 0 for a leaf
  std::uint32_t leaf_count{0};     // leaves under the node (1 for a leaf)
  std::uint32_t data{0};           // private: leaf slot or interior record index
  glm::vec3 centre{0.0f};          // bounding sphere of the leaves' 3-sigma ellipsoids:
  float radius{0.0f};              //   view-dependent error = radius / distance
  std::uint16_t height{0};         // 0 for a leaf, else 1 + the highest child's
  bool live{false};
  bool leaf{false};
};

// What an update changed among the interior nodes (the records the host sends), each list
// sorted by id. Leaf edits are the scene's own (the changes given), only counted here.
struct LodUpdateReport {
  std::vector<GaussianId> added;     // interior nodes that are new
  std::vector<GaussianId> removed;   // interior nodes retired
  std::vector<GaussianId> modified;  // kept interior nodes whose record's bits changed
  std::size_t leaves_inserted{0};
  std::size_t leaves_modified{0};
  std::size_t leaves_removed{0};
  std::size_t skipped{0};            // Gaussians left out as unusable (lod_merge.h LodLeafStatus)
  std::size_t nodes_merged{0};       // interior records recomputed (the update's work)
  // The children those merges read, leaves and interior nodes: the update's work in a full
  // build's units, since a build reads every node but the root once (leaf_count() +
  // interior_count() - 1).
  std::size_t inputs_merged{0};
};

class LodHierarchy {
 public:
  // An empty hierarchy for scenes of this SH degree. Fails on a degree outside 0..3, or
  // max_leaves_per_node outside 2..64, or max_scale not positive and finite, or a cube with a
  // negative, non-finite or non-finite-origin edge.
  static Expected<LodHierarchy> create(int sh_degree, const LodConfig& config = {});
  // create() then update(gaussians): the full build.
  static Expected<LodHierarchy> build(std::span<const Gaussian> gaussians, int sh_degree,
                                      const LodConfig& config = {});

  // Brings the hierarchy to exactly `gaussians` (the new epoch's eligible set): ids not
  // present are removed, new ids inserted, ids whose value differs (position, log_scale,
  // rotation, opacity, colour up to the degree, object, support) modified. Fails, changing
  // nothing, on a duplicate id or an id with the top bit set (naming it).
  Expected<LodUpdateReport> update(std::span<const Gaussian> gaussians);
  // The same over part of a scene: gaussians[i] for each i in `subset` (an eligible set's
  // indices), without copying them out. Fails, changing nothing, on an index outside the span.
  Expected<LodUpdateReport> update(std::span<const Gaussian> gaussians, std::span<const std::uint32_t> subset);
  // The same from a change list: `upserts` are inserted or (when the id is a leaf) modified,
  // `removed` removed. Fails, changing nothing, on an id given twice, a removed id that is not
  // a leaf (unless it was skipped before: unknown ids are ignored only if `lenient_removes`),
  // or an id with the top bit set.
  Expected<LodUpdateReport> apply(std::span<const Gaussian> upserts, std::span<const GaussianId> removed,
                                  bool lenient_removes = false);

  // --- reading --------------------------------------------------------------------------
  std::uint32_t root() const { return root_; }  // kNoLodNode when empty
  const LodNode& node(std::uint32_t index) const { return nodes_[index]; }
  std::span<const LodNode> nodes() const { return nodes_; }  // the pool: has dead entries
  std::span<const std::uint32_t> children(const LodNode& n) const {
    return std::span<const std::uint32_t>(children_).subspan(n.first_child, n.child_count);
  }
  // The record of an interior node (id set); for a leaf use leaf_gaussian().
  const Gaussian& record(const LodNode& n) const { return records_[n.data]; }
  // Every interior record slot (live or free) and an interior node's slot in it: a cut hands
  // the differ this span, so a record is read where it lies instead of being copied out.
  // Valid until the next update.
  std::span<const Gaussian> record_pool() const { return records_; }
  std::uint32_t record_slot(const LodNode& n) const { return n.data; }
  // A leaf's Gaussian as stored (carrier false; SH rest above the degree zero).
  Gaussian leaf_gaussian(const LodNode& n) const;
  // The node's Gaussian whichever kind it is.
  Gaussian gaussian(const LodNode& n) const { return n.leaf ? leaf_gaussian(n) : record(n); }
  // Pool index of the root of object `o`'s subtree (its only leaf when it has one), or
  // kNoLodNode when no leaf of it is in the hierarchy (or o is kNoObject / negative).
  std::uint32_t object_root(ObjectId o) const;
  // Where a leaf was in the span the last update() that saw it read (its index there), or
  // kNoLodSource when apply() inserted it (apply() keeps a modified leaf's). The caller knows
  // whether that span's places still hold (a SceneStore's do, but for its tail).
  std::uint32_t leaf_source(const LodNode& n) const { return leaf_source_[n.data]; }
  // Pool index of the leaf with this id, or kNoLodNode.
  std::uint32_t find_leaf(GaussianId id) const;
  std::size_t leaf_count() const { return leaf_index_.size(); }
  std::size_t interior_count() const { return interior_live_; }
  int sh_degree() const { return sh_degree_; }
  // The quantisation cube in use (edge 0 until the first non-empty update fixed it).
  LodCube cube() const { return cube_set_ ? LodCube{cube_min_, double(1u << 21) / cell_inv_} : LodCube{}; }
  const LodConfig& config() const { return config_; }
  // Changes whenever an update may have changed anything (nodes, records, leaf places),
  // successful or not; unique across every hierarchy of the process, so a reader caching
  // something derived from one (LodCutter's layout) knows when it is stale, even when another
  // hierarchy now lives at the same address.
  std::uint64_t generation() const { return generation_; }
  // The bytes the pools hold now (their capacities).
  std::size_t memory_bytes() const;
  // About the most a hierarchy of `leaves` leaves at this SH degree takes while it is built:
  // pools and the build's scratch, with interior nodes for half the leaves (random scenes
  // have 0.35 per leaf). An upper bound for the memory_bytes() of typical scenes (a test
  // checks), not for every layout.
  static std::size_t bytes_for(std::size_t leaves, int sh_degree);

 private:
  struct LeafFields {  // what a leaf's value is (compared by update(), merged by its parent)
    glm::vec3 position;
    glm::vec3 log_scale;
    glm::vec4 rotation;
    float opacity_logit;
    glm::vec3 sh_dc;
    ObjectId object;
    std::uint32_t support;
  };
  struct InteriorKey {  // the cell an interior node is
    std::uint32_t tree{0};  // object id, kBackgroundTree, kObjectsTree or kRootTree
    std::uint8_t level{0};
    // A node split by octant: bit d set for each octant with leaves, whose children are in
    // octant order, so the descent finds an old child's octant without reading the child. 0
    // for a node whose children are its cell's leaves (or another tree's roots) as they come.
    std::uint8_t octants{0};
    std::uint64_t prefix{0};
  };
  struct Entry {  // one leaf in the sorted order: tree, then code, then id (the node's)
    std::uint32_t tree;
    std::uint32_t node;
    std::uint64_t code;
  };
  struct TreeBuild;
  struct CellChanges;
  struct DeferredMerge {  // an interior node an update merges once the trees' shapes stand
    std::uint32_t node;
    bool kept;  // it stood before the update (merge_kids' `kept`)
  };

  LodHierarchy() = default;

  // lod_hierarchy.cpp
  template <typename Get>
  Expected<LodUpdateReport> update_from(const Gaussian* base, std::size_t count, Get&& get);
  Expected<LodUpdateReport> apply_changes(std::span<const Gaussian* const> upserts,
                                          std::span<const GaussianId> removed, bool lenient);
  // Steps 4-5 of an update: rebuilds the group trees named in `dirty` ((tree, code) of every
  // changed leaf, sorted, unique), then the objects tree and the root as needed. `all_new`:
  // the full build (no old tree; every leaf of the order is visited).
  // `fresh` and `leaving`: the entries entering and leaving the order (sorted; empty in a
  // full build).
  void update_trees(std::span<const std::pair<std::uint32_t, std::uint64_t>> dirty, std::span<const Entry> fresh,
                    std::span<const Entry> leaving, LodUpdateReport& report, std::vector<std::uint32_t>& retired,
                    bool all_new);
  // Step 3 of an update: `leaving` (entries as they stand) out of order_, `fresh` in, order_
  // sorted by (tree, code, id) after as before. Both lists sorted so (sort_entries).
  void update_order(std::span<const Entry> leaving, std::span<const Entry> fresh);
  // The order's order: tree, code, then the node's id (sort_entries sorts by it).
  bool entry_less(const Entry& a, const Entry& b) const;
  void sort_entries(std::span<Entry> list) const;
  // (tree, code) of every entry of the three sorted lists, sorted, each once: the cells an
  // update's descent must visit.
  static std::vector<std::pair<std::uint32_t, std::uint64_t>> changed_places(std::span<const Entry> leaving,
                                                                             std::span<const Entry> fresh,
                                                                             std::span<const Entry> in_place);
  void sort_report(LodUpdateReport& report) const;
  std::uint64_t morton(const glm::vec3& p) const;
  std::uint32_t tree_of(ObjectId o) const;
  std::uint32_t alloc_node();
  void store_leaf(std::uint32_t node, const Gaussian& g);
  bool same_leaf_value(std::uint32_t node, const Gaussian& g) const;
  void compact_children();
  void next_generation();
  // A fresh touch_stamp_ mark (every entry's marks cleared when the counter wraps).
  std::uint32_t next_stamp();
  // Fixes the cube around [lo, hi] (the first non-empty epoch's usable positions) unless it is
  // fixed already or the box is empty.
  void fix_cube(const glm::dvec3& lo, const glm::dvec3& hi);
  // lod_full_build.cpp
  Expected<LodUpdateReport> build_from_empty(std::span<const Gaussian* const> gaussians, const Gaussian* base);
  void clear_pools();
  // lod_tree_build.cpp
  std::uint32_t build_cell(TreeBuild& b, std::span<const Entry> items, int level, std::uint64_t prefix,
                           std::uint32_t candidate, const CellChanges& changes);
  std::uint32_t make_interior(TreeBuild& b, int level, std::uint64_t prefix, std::uint32_t reuse,
                              std::span<const std::uint32_t> kids, std::uint8_t octants);
  // The node's moments, record, sphere, leaf count and height from `kids` (its children,
  // in order). `kept`: the node stood before this update with the record it holds (the
  // report lists it as modified if its record's bits change; a recolouring keeps its
  // geometry). The record's geometry may wait in b.pending until flush_geometry(b).
  void merge_kids(TreeBuild& b, std::uint32_t node, bool kept, std::span<const std::uint32_t> kids);
  // Gives every record waiting in b.pending its geometry. Due before a TreeBuild is done.
  void flush_geometry(TreeBuild& b);
  // An update that moved no leaf to another cell, added none and removed none leaves every
  // tree's shape as it was: only the nodes above the `changed` leaves are merged again,
  // bottom-up, each from its children as they stand (what the recursion from the root would
  // do to them, without the descent).
  void remerge_ancestors(std::span<const std::uint32_t> changed, LodUpdateReport& report);
  // merge_kids of each listed node (children listed before parents), a batch at a time.
  void merge_in_batches(TreeBuild& b, std::span<const DeferredMerge> list);
  void retire_subtree(TreeBuild& b, std::uint32_t node);
  void retire_node(TreeBuild& b, std::uint32_t node);
  void node_moments(std::uint32_t node, LodMoments& m, std::span<glm::dvec3> rest) const;
  // Loads issued back to back so that their misses overlap (lod_tree_build.cpp): a full
  // build's leaves a cell at a time, the reads of a batch of merges, the old paths an
  // update's descent will walk.
  void warm_leaves(std::span<const Entry> items) const;
  void warm_merges(std::span<const std::uint32_t> nodes) const;
  void warm_descent(std::span<const Entry> leaving);
  // visit(p) for every ancestor p of the `from` nodes, once each, a level at a time
  // (lod_tree_build.cpp, its only users).
  template <class Visit>
  void for_each_ancestor(std::vector<std::uint32_t> from, Visit&& visit);
  void leaf_slot_moments(std::uint32_t slot, LodMoments& m, glm::dvec3* rest) const;

  LodConfig config_;
  int sh_degree_{0};
  int rest_count_{0};

  // Quantisation cube (fixed at the first non-empty update).
  bool cube_set_{false};
  glm::dvec3 cube_min_{0.0};
  double cell_inv_{1.0};  // 2^21 / cube edge

  // The pools sit on huge pages where the system allows. Leaves are read at random (a build
  // reads them in tree order, an update's merges by cell): at 1M leaves nodes and fields span
  // ~110 MB, and on 4 KiB pages nearly every such read also missed the TLB. And a build
  // writes ~400 MB of new pools: on 4 KiB pages a tenth of its time went to page faults.
  template <class T>
  using Pool = detail::TableVector<T>;
  Pool<LodNode> nodes_;
  std::vector<std::uint32_t> free_nodes_;
  Pool<std::uint32_t> children_;
  std::size_t children_garbage_{0};
  // compact_children()'s other buffer, kept with its capacity: every update appends its
  // nodes' runs to children_, so without it each compaction's exact-size copy grew again
  // (a reallocation onto fresh, zeroed pages) within a few updates.
  Pool<std::uint32_t> children_spare_;
  // Leaf slots (node.data of a leaf): fields and SH rest (rest_count_ triples per slot).
  Pool<LeafFields> leaf_fields_;
  Pool<glm::vec3> leaf_rest_;
  Pool<std::uint32_t> leaf_source_;  // per leaf slot: index in the last update()'s span
  // The reverse, per place k of the last update()'s input (the k-th Gaussian it read): the
  // leaf node it became, or kNoLodNode. A hint only: update() tries gaussians[k] against this
  // node first (a sequential read when the epochs keep their order) and trusts it only if
  // that node is a live leaf with the same id; anything else is looked up by id.
  Pool<std::uint32_t> input_nodes_;
  std::vector<std::uint32_t> free_leaf_slots_;
  detail::IdIndex leaf_index_;  // leaf id -> node
  // Interior slots (node.data of an interior node).
  Pool<Gaussian> records_;
  // Moments in double, for the node's geometry, weight and DC colour. Its SH rest moments
  // are its record's (floats): at SH 3 a double copy was 360 bytes a node, a fifth of a 1M
  // build's fresh memory (node_moments).
  Pool<LodMoments> moments_;
  Pool<InteriorKey> keys_;
  std::vector<std::uint32_t> free_interior_slots_;
  std::size_t interior_live_{0};
  std::uint64_t next_serial_{0};

  Pool<Entry> order_;  // every leaf, sorted by (tree, code, id)
  Pool<Entry> order_scratch_;
  // Per pool entry: the update that last touched it (duplicate ids are found without a sort).
  Pool<std::uint32_t> touch_stamp_;
  std::uint32_t stamp_{0};
  // Root node of each group tree, sorted by tree.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> group_roots_;
  std::uint32_t objects_root_{kNoLodNode};
  std::uint32_t root_{kNoLodNode};
  std::uint64_t generation_{0};
};

}  // namespace gauss
