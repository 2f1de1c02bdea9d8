#pragma once
// Scene sources: where the host's epochs come from.
//  (a) synthetic evolving rooms (the embedded default, SyntheticScene),
//  (b) a folder of snapshots replayed as epochs, flat (<any>N.ply|.splat|.spz|.sog, ordered
//      by the last number in the name) or as 3DGS trainers write it
//      (point_cloud/iteration_N/point_cloud.ply, ordered by N), with optional meshes, labels
//      and an objects JSON,
//  (c) one scene file as one epoch.
// Scene files are read in any format splat_file.h knows, detected by content.
// Each next_epoch() commits at most one epoch to the store. A snapshot that cannot be used
// (missing, corrupt, NaN, labels of the wrong length) is logged and skipped: the store keeps
// its last good epoch and the source moves on to the next snapshot; one written less than
// `settle_s` ago is waited for instead (a trainer may still be writing it). Snapshots
// without gaussian_id get ids from identity tracking against the store's current epoch.
#include <cstddef>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/identity_tracker.h"
#include "gauss/engine/mesh.h"
#include "gauss/engine/objects_json.h"
#include "gauss/engine/result.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/synthetic_scene.h"

namespace gauss {

// Receives one line per recoverable problem (skipped snapshot, ignored file).
using SourceLog = std::function<void(const std::string&)>;

class SceneSource {
 public:
  virtual ~SceneSource() = default;
  // Commits the next epoch to `store`: true when one was committed, false when the source
  // has nothing more (now; a folder source rescans on every call, so a trainer still
  // writing may add more later). An error means nothing usable exists at all (e.g. the only
  // snapshot is bad and no epoch was ever produced) or the store has an open epoch.
  virtual Expected<bool> next_epoch(SceneStore& store) = 0;
  // Seconds the host should wait between epochs (the configured replay rate).
  virtual double epoch_period_s() const = 0;
  // A snapshot is being prepared in the background (SnapshotOptions::prepare_in_background):
  // next_epoch's false meant "not yet", and the next call may commit it.
  virtual bool busy() const { return false; }
  virtual std::string describe() const = 0;
  // Every message sent to the log so far.
  const std::vector<std::string>& messages() const { return messages_; }

 protected:
  explicit SceneSource(SourceLog log) : log_(std::move(log)) {}
  void report(const std::string& line);

 private:
  SourceLog log_;
  std::vector<std::string> messages_;
};

// (a) The embedded default (set scene.surface_chunk for the analytic stand-in surface).
struct SyntheticSourceOptions {
  SyntheticSceneConfig scene;
  double rate_hz{10.0};
};
Expected<std::unique_ptr<SceneSource>> open_synthetic_source(const SyntheticSourceOptions& options,
                                                             SourceLog log = {});

struct SnapshotOptions {
  double rate_hz{1.0};                                 // epochs per second, > 0
  std::optional<std::filesystem::path> objects_json;   // default: <folder>/objects.json if present
  // Labels for every snapshot (one integer per Gaussian, io's labels format). Default: a
  // per-snapshot file (<stem>_labels.txt beside a flat snapshot, labels.txt in an iteration
  // folder) when present. Labels override a PLY object_id property.
  std::optional<std::filesystem::path> labels;
  bool label_zero_is_unlabelled{true};  // label 0 -> no object (negative labels always are)
  // A folder's snapshot that fails to load but was written less than this many seconds ago
  // is retried on the next call rather than skipped: a half-written file is not corrupt yet.
  double settle_s{2.0};
  // The surface: `mesh` (a mesh PLY) for every snapshot instead of the meshes found beside
  // them; `snapshot_meshes` false ignores those too (a host fusing its own surface).
  std::optional<std::filesystem::path> mesh;
  bool snapshot_meshes{true};
  IdentityTrackerConfig identity;       // for snapshots without gaussian_id
  // A followed folder's snapshot in which more than this fraction of the Gaussians hold a
  // NaN or Inf (a trainer that diverged) is skipped like a broken one while the store holds
  // an earlier snapshot: what was good is kept. Below it, or with nothing to keep (the first
  // snapshot, a scene file), the snapshot is applied without them (splat_file.h).
  double max_non_finite_fraction{0.01};
  // A followed folder's snapshots are read, checked and matched with the scene (identity
  // tracking) on a thread of the source's own, and next_epoch only commits them: at a million
  // Gaussians that work is seconds, which a host's serving thread spent answering nobody.
  // next_epoch then returns false while one is being read (busy()), and the store given to it
  // must outlive the source and be changed by nothing else meanwhile (a commit finding it at
  // another epoch prepares the snapshot again, on the caller's thread). A scene file is
  // read at once either way.
  bool prepare_in_background{false};
};

// A folder of snapshots (to open with open_snapshot_folder), as opposed to a scene file or a
// SOG folder (a folder holding meta.json, opened with open_scene_file).
bool is_snapshot_folder(const std::filesystem::path& path);

// (b) Lists the folder now (and again on each next_epoch). Fails when the folder does not
// exist or the objects JSON is bad. An empty folder is not an error (nothing yet).
// Meshes: <stem>_mesh.ply beside a flat snapshot, mesh.ply in an iteration folder, or
// <folder>/mesh.ply for all; set as surface chunk 0 whenever the snapshot's mesh changes.
Expected<std::unique_ptr<SceneSource>> open_snapshot_folder(const std::filesystem::path& folder,
                                                            const SnapshotOptions& options = {},
                                                            SourceLog log = {});
// (c) One scene file (any splat format, or a SOG folder) as one epoch (then exhausted). Mesh
// and labels as given in options, or <stem>_mesh.ply / <stem>_labels.txt beside it.
Expected<std::unique_ptr<SceneSource>> open_scene_file(const std::filesystem::path& ply,
                                                       const SnapshotOptions& options = {}, SourceLog log = {});

// What a snapshot did to the store.
struct SnapshotApplyReport {
  std::size_t inserted{0}, modified{0}, removed{0}, unchanged{0};
  bool tracked{false};  // ids came from identity tracking (the PLY had no gaussian_id)
  IdentityReport identity;
};

// Commits one epoch that makes the store's Gaussians equal to `cloud`: ids absent from the
// cloud are removed, changed ones modified, new ones inserted. With `ids_given` the cloud's
// ids are used (an id removed earlier is an error: ids are never reused); otherwise ids come
// from identity tracking. Validates everything before opening the epoch, so on error the
// store is untouched.
// `objects` are declared (labels, quality) and `mesh`, when given, becomes surface chunk 0,
// both in the same epoch.
Expected<SnapshotApplyReport> apply_snapshot(SceneStore& store, GaussianCloud cloud, bool ids_given,
                                             const IdentityTrackerConfig& identity = {},
                                             const std::vector<ObjectLabel>& objects = {},
                                             const TriangleMesh* mesh = nullptr);

// apply_snapshot in two steps, so the long one (the checks and the identity tracking: seconds
// at a million Gaussians) can run on another thread while the store is read by others but
// changed by nobody: prepare_snapshot only reads the store; commit_snapshot opens and commits
// the epoch. Together they are apply_snapshot, id for id (the fresh ids tracking hands out are
// placeholders until the commit allocates them, in the same order).
struct PreparedSnapshot {
  Epoch against{0};  // the store's epoch when prepared: a commit to any other is refused
  GaussianCloud cloud;
  std::vector<ObjectLabel> objects;
  std::optional<TriangleMesh> mesh;
  std::vector<GaussianId> gone;  // the store's ids the snapshot no longer has
  std::size_t entering{0};       // its Gaussians new to the store
  std::size_t fresh{0};          // of which given fresh ids at the commit (tracking)
  SnapshotApplyReport report;    // tracked and identity so far
};
Expected<PreparedSnapshot> prepare_snapshot(const SceneStore& store, GaussianCloud cloud, bool ids_given,
                                            const IdentityTrackerConfig& identity = {},
                                            std::vector<ObjectLabel> objects = {},
                                            std::optional<TriangleMesh> mesh = std::nullopt);
// Fails, changing nothing, when the store has an open epoch or is no longer at the epoch the
// snapshot was prepared against (prepare it again).
Expected<SnapshotApplyReport> commit_snapshot(SceneStore& store, PreparedSnapshot prepared);

// Sets Gaussian objects from per-Gaussian labels, one per Gaussian of the file in its order:
// `dropped` are the file indices its reader left out (SplatFileReport::dropped, ascending),
// whose labels are skipped. Error on a length mismatch, naming both.
Status apply_labels(GaussianCloud& cloud, const std::vector<std::int32_t>& labels, bool zero_is_unlabelled,
                    const std::string& labels_name, const std::string& scene_name,
                    std::span<const std::size_t> dropped = {});

}  // namespace gauss
