#pragma once
// SceneStore: the host's evolving scene, epoch by epoch.
//
// Contents: Gaussians keyed by persistent GaussianId, the semantic object table, and
// surface mesh chunks. Every mutation happens inside an open epoch
// (begin_epoch ... commit_epoch); the change log records, per committed epoch, which ids
// were inserted / modified / removed so consumers (selector, differ) can be incremental.
//
// Storage contract (what readers may rely on):
// - gaussians() is one contiguous, dense span. Its order is stable between epochs except
//   for removals: new Gaussians are appended at the end; at commit each removed Gaussian's
//   place is filled by the last Gaussian of the span (so a removal moves at most one other
//   Gaussian, and commit costs O(changes), not O(N)).
// - While an epoch is open, mutations are applied at once to find(), but removed
//   Gaussians stay in the span until commit_epoch(); read the span between epochs.
// - Carriers (Gaussian::carrier) are stored and iterable (they carry object ids for
//   upstream semantic association) but never count as appearance: they are excluded from
//   appearance_count(), object members, object centroids/extents and bounds().
// - Ids are never reused within a session: inserting an id that is live or was removed
//   before is an error. allocate_id() hands out fresh ids above every id seen.
// Not thread-safe: one writer, readers between epochs (the host loop owns it).
#include <cstddef>
#include <cstdint>
#include <deque>
#include <limits>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/compact_id_set.h"
#include "gauss/engine/gaussian.h"
#include "gauss/engine/id_index.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/mesh.h"
#include "gauss/engine/result.h"
#include "gauss/engine/semantic.h"

namespace gauss {

// A piece of the surface mesh with the source epoch it came from.
struct SurfaceChunk {
  std::uint32_t chunk_id{0};
  Epoch epoch{0};
  TriangleMesh mesh;
};

// Axis-aligned box; empty (min > max) until a point is added.
struct Aabb {
  glm::vec3 min{std::numeric_limits<float>::max()};
  glm::vec3 max{std::numeric_limits<float>::lowest()};
  bool empty() const { return min.x > max.x || min.y > max.y || min.z > max.z; }
  void extend(const glm::vec3& p);
};

// What one committed epoch changed. An id appears in at most one of the three lists:
// inserted then modified in the same epoch is "inserted"; inserted then removed in the
// same epoch appears nowhere; modified then removed is "removed". Lists are sorted by id.
struct EpochChanges {
  Epoch epoch{0};
  std::vector<GaussianId> inserted;
  std::vector<GaussianId> modified;
  std::vector<GaussianId> removed;
  bool objects_changed{false};                  // object table or any membership changed
  std::vector<std::uint32_t> chunks_changed;    // surface chunk ids set or removed (sorted)
};

class SceneStore {
 public:
  // How many committed epochs the change log keeps (oldest dropped first).
  explicit SceneStore(std::size_t change_log_capacity = 64);

  // --- epochs -------------------------------------------------------------------------
  // Last committed epoch; Epoch{0} before the first commit.
  Epoch epoch() const { return epoch_; }
  bool in_epoch() const { return open_; }
  // Opens epoch `e`. Fails when an epoch is already open or e <= epoch().
  Status begin_epoch(Epoch e);
  // Opens epoch() + 1.
  Status begin_next_epoch();
  // Fills removed places (see above), recomputes object membership/centroids/extents and bounds,
  // appends the change log entry and makes the epoch current. Fails when none is open.
  Status commit_epoch();
  // Makes room, before an epoch opens, for a span of `span` Gaussians at its peak (the live
  // ones plus those the epoch will insert; removed ones leave at commit), so that a snapshot
  // too large for this process is refused before the store changes. Fails, changing nothing,
  // when that would take more memory than the process can still have (memory_headroom()) or
  // an allocation fails; the message has the figures. bytes_to_hold() is the estimate.
  Status reserve(std::size_t span);
  std::size_t bytes_to_hold(std::size_t span) const;

  // --- Gaussians (inside an open epoch only) -------------------------------------------
  // Fails when no epoch is open, the id is live or was used before, or a field is
  // non-finite / the SH degree of the Gaussian's non-zero rest exceeds sh_degree().
  Status insert(const Gaussian& g);
  // Replaces the record of live id g.id. Fails when g.id is not live or g is not finite.
  // A modify whose record is bit-identical to the stored one is not logged.
  Status modify(const Gaussian& g);
  // Removes live id. Fails when it is not live.
  Status remove(GaussianId id);
  // Why `g` cannot be stored in a scene of this SH degree (non-finite field, non-zero SH
  // rest above the degree, object id below -1), or Ok. insert/modify apply this check.
  static Status validate(const Gaussian& g, int sh_degree);
  // A fresh id: larger than any id ever inserted or allocated in this store.
  GaussianId allocate_id();

  // --- reading ----------------------------------------------------------------------
  const Gaussian* find(GaussianId id) const;
  bool contains(GaussianId id) const { return find(id) != nullptr; }
  // True when `id` was live once and removed: it may never be inserted again.
  bool was_removed(GaussianId id) const { return retired_.contains(id); }
  // All stored Gaussians (carriers included), see the storage contract above.
  std::span<const Gaussian> gaussians() const { return gaussians_; }
  // Live Gaussians (carriers included).
  std::size_t size() const { return index_.size(); }
  // Live non-carrier Gaussians: what appearance residency is measured against.
  std::size_t appearance_count() const { return appearance_count_; }
  std::size_t carrier_count() const { return size() - appearance_count_; }
  // Bounds of the live appearance Gaussians' centres at the last commit.
  const Aabb& bounds() const { return bounds_; }

  // SH degree the scene carries (0..3); rest coefficients beyond it must be zero.
  int sh_degree() const { return sh_degree_; }
  // Fails when degree is outside 0..3 or a stored Gaussian has non-zero rest above it.
  Status set_sh_degree(int degree);

  // --- semantic objects ---------------------------------------------------------------
  // Sorted by object id. Members (sorted ids), centroid, extent are derived from the
  // appearance Gaussians whose `object` is the object's id, recomputed at commit.
  // An object id used by Gaussians but never declared appears with an empty label.
  const std::vector<SemanticObject>& objects() const { return objects_; }
  const SemanticObject* find_object(ObjectId id) const;
  // Declares or relabels an object (inside an open epoch). quality in [0, 1].
  // Fails on kNoObject / negative id, an empty label, or quality outside [0, 1].
  Status set_object(ObjectId id, std::string label, float quality = 1.0f);
  // Forgets a declared object. Gaussians keep their object id (it reappears unlabelled).
  Status remove_object(ObjectId id);

  // --- surface ------------------------------------------------------------------------
  // Sets or replaces chunk `chunk.chunk_id` (inside an open epoch). The chunk's epoch is
  // forced to the open epoch. Fails on indices out of range, a colours/positions length
  // mismatch, an index count that is not a multiple of 3, or a non-finite position.
  Status set_surface_chunk(SurfaceChunk chunk);
  // The mesh checks set_surface_chunk applies, for validating before an epoch opens.
  static Status validate(const TriangleMesh& mesh);
  Status remove_surface_chunk(std::uint32_t chunk_id);
  // Sorted by chunk id.
  const std::vector<SurfaceChunk>& surface_chunks() const { return chunks_; }

  // --- change log ---------------------------------------------------------------------
  // Oldest first; at most change_log_capacity entries.
  const std::deque<EpochChanges>& change_log() const { return log_; }
  // The entry for epoch e, or nullptr when it is older than the log keeps or never was.
  const EpochChanges* changes(Epoch e) const;

 private:
  // What happened to an id during the open epoch (collapsed to one entry per id).
  enum class Pending : std::uint8_t { None, Inserted, Modified, Removed, InsertedThenRemoved };
  static bool dead(Pending p) { return p == Pending::Removed || p == Pending::InsertedThenRemoved; }
  Status require_open(const char* what) const;
  void recompute_derived();

  Epoch epoch_{0};
  bool open_{false};
  Epoch open_epoch_{0};
  int sh_degree_{0};
  std::size_t log_capacity_;
  std::uint64_t next_id_{1};

  // On huge pages from 4 MiB (detail::TableAllocator), however it grows (a snapshot's
  // reserve, or insert's doubling): the serving path reads Gaussians scattered through it
  // (a diff's entering records, a cut's leaves), and on 4 KiB pages nearly every such read
  // also missed the TLB. Before, only a reserve's fresh room was advised, and a scene grown by
  // inserts (the synthetic room, RGB-D fusion) stayed on small pages: at 1M Gaussians and
  // M = 200k the LoD walk's diff took 5.9 ms (median) against 3.3 with the same scene
  // collapsed onto huge pages.
  std::vector<Gaussian, detail::TableAllocator<Gaussian>> gaussians_;
  std::vector<Pending> pending_;       // parallel to gaussians_: what the open epoch did to it
  std::vector<std::uint32_t> touched_; // places whose pending_ left None this epoch (each once)
  std::unordered_map<GaussianId, std::uint32_t> index_;  // live id -> position in gaussians_
  CompactIdSet retired_;                                 // removed ids, never reused
  std::size_t appearance_count_{0};
  Aabb bounds_;

  struct DeclaredObject {
    std::string label;
    float quality{1.0f};
  };
  std::unordered_map<ObjectId, DeclaredObject> declared_;
  std::vector<SemanticObject> objects_;
  std::vector<SurfaceChunk> chunks_;

  bool pending_objects_changed_{false};
  std::vector<std::uint32_t> pending_chunks_;
  std::deque<EpochChanges> log_;
};

}  // namespace gauss
