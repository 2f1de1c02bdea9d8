// Turning a whole snapshot (a GaussianCloud) into one SceneStore epoch, plus labels.
#include <algorithm>
#include <new>
#include <string>
#include <unordered_set>

#include "gauss/engine/kept_file_indices.h"
#include "gauss/engine/labels_io.h"
#include "gauss/engine/scene_source.h"

namespace gauss {

namespace {

// Fresh ids tracking hands out before the commit: the placeholder bit and a count. No store
// id has the top bit (SceneStore refuses it), and the commit replaces every placeholder.
constexpr std::uint64_t kPlaceholder = std::uint64_t{1} << 63;

// The snapshot's ids (given, or tracked from the scene's, fresh ones as placeholders), the
// scene's ids it no longer has and how many of its Gaussians are new to the scene.
Status match_ids(const SceneStore& store, GaussianCloud& cloud, bool ids_given, const IdentityTrackerConfig& identity,
                 SnapshotApplyReport& report, std::vector<GaussianId>& gone, std::size_t& entering,
                 std::size_t& fresh) {
  if (ids_given) {
    std::unordered_set<GaussianId> seen;
    seen.reserve(cloud.gaussians.size());
    for (const Gaussian& g : cloud.gaussians) {
      if (!seen.insert(g.id).second)
        return Error{"apply_snapshot: gaussian_id " + std::to_string(to_underlying(g.id)) + " appears twice"};
      if (store.was_removed(g.id))
        return Error{"apply_snapshot: gaussian_id " + std::to_string(to_underlying(g.id)) +
                     " was removed in an earlier epoch; ids are never reused"};
    }
  } else {
    auto r = track_identity(store.gaussians(), cloud.gaussians, identity,
                            [&] { return GaussianId{kPlaceholder | fresh++}; });
    if (!r) return Error{"apply_snapshot: " + r.message()};
    report.tracked = true;
    report.identity = *r;
  }

  {
    std::unordered_set<GaussianId> in_cloud;
    in_cloud.reserve(cloud.gaussians.size());
    for (const Gaussian& g : cloud.gaussians) in_cloud.insert(g.id);
    for (const Gaussian& g : store.gaussians())
      if (!in_cloud.count(g.id)) gone.push_back(g.id);
  }

  // Tracking counted them (its fresh ids); given ids are looked up.
  if (report.tracked) {
    entering = report.identity.fresh;
  } else {
    for (const Gaussian& g : cloud.gaussians)
      if (!store.contains(g.id)) ++entering;
  }
  return Ok{};
}

}  // namespace

Status apply_labels(GaussianCloud& cloud, const std::vector<std::int32_t>& labels, bool zero_is_unlabelled,
                    const std::string& labels_name, const std::string& scene_name, std::span<const std::size_t> dropped) {
  if (auto s = check_label_count(labels, cloud.gaussians.size() + dropped.size(), labels_name, scene_name); !s)
    return s;
  KeptFileIndices file_index(dropped);
  for (Gaussian& g : cloud.gaussians) {
    const std::int32_t l = labels[file_index.next()];
    g.object = (l < 0 || (zero_is_unlabelled && l == 0)) ? kNoObject : ObjectId{l};
  }
  return Ok{};
}

Expected<PreparedSnapshot> prepare_snapshot(const SceneStore& store, GaussianCloud cloud, bool ids_given,
                                            const IdentityTrackerConfig& identity, std::vector<ObjectLabel> objects,
                                            std::optional<TriangleMesh> mesh) {
  if (store.in_epoch()) return Error{"apply_snapshot: the store has an open epoch"};
  if (cloud.sh_degree < 0 || cloud.sh_degree > kMaxShDegree)
    return Error{"apply_snapshot: SH degree " + std::to_string(cloud.sh_degree) + " is outside 0..3"};
  // Everything is checked before the epoch opens, so a bad snapshot leaves the store as it was.
  for (std::size_t i = 0; i < cloud.gaussians.size(); ++i)
    if (auto s = SceneStore::validate(cloud.gaussians[i], cloud.sh_degree); !s)
      return Error{"apply_snapshot: Gaussian " + std::to_string(i) + ": " + s.message()};
  for (const ObjectLabel& o : objects)
    if (to_underlying(o.id) < 0 || o.label.empty() || !(o.quality >= 0.0f && o.quality <= 1.0f))
      return Error{"apply_snapshot: object " + std::to_string(to_underlying(o.id)) + " has a bad id, label or quality"};

  if (mesh)
    if (auto s = SceneStore::validate(*mesh); !s) return Error{"apply_snapshot: mesh: " + s.message()};

  PreparedSnapshot p;
  p.against = store.epoch();
  // The comparison with the scene holds sets of every id: a scene too large for the process
  // is refused here, the store unchanged.
  try {
    if (auto s = match_ids(store, cloud, ids_given, identity, p.report, p.gone, p.entering, p.fresh); !s)
      return s.error();
  } catch (const std::bad_alloc&) {
    return Error{"apply_snapshot: not enough memory to compare " + std::to_string(cloud.gaussians.size()) +
                 " Gaussians with the scene's " + std::to_string(store.size())};
  }
  p.cloud = std::move(cloud);
  p.objects = std::move(objects);
  p.mesh = std::move(mesh);
  return p;
}

Expected<SnapshotApplyReport> commit_snapshot(SceneStore& store, PreparedSnapshot prepared) {
  if (store.in_epoch()) return Error{"apply_snapshot: the store has an open epoch"};
  if (store.epoch() != prepared.against)
    return Error{"apply_snapshot: prepared against epoch " + std::to_string(to_underlying(prepared.against)) +
                 ", the store is at epoch " + std::to_string(to_underlying(store.epoch()))};
  if (auto s = store.reserve(store.gaussians().size() + prepared.entering); !s)
    return Error{"apply_snapshot: " + s.message()};
  // The fresh ids, in the order tracking handed out their placeholders (snapshot order).
  if (prepared.fresh > 0) {
    std::vector<GaussianId> fresh(prepared.fresh);
    for (GaussianId& id : fresh) id = store.allocate_id();
    for (Gaussian& g : prepared.cloud.gaussians)
      if (to_underlying(g.id) & kPlaceholder) g.id = fresh[to_underlying(g.id) & ~kPlaceholder];
  }
  const GaussianCloud& cloud = prepared.cloud;
  SnapshotApplyReport& report = prepared.report;

  if (auto s = store.begin_next_epoch(); !s) return s.error();
  // Past validation nothing below should fail; if it does, commit what was applied (the
  // store stays consistent) and report the first error.
  Status first_error = Ok{};
  const auto check = [&](Status s) {
    if (!s && first_error) first_error = std::move(s);
  };
  if (cloud.sh_degree > store.sh_degree()) check(store.set_sh_degree(cloud.sh_degree));
  for (GaussianId id : prepared.gone) {
    check(store.remove(id));
    ++report.removed;
  }
  for (const Gaussian& g : cloud.gaussians) {
    if (const Gaussian* old = store.find(g.id)) {
      const bool changed = !same_value(*old, g);
      if (changed) {
        check(store.modify(g));
        ++report.modified;
      } else {
        ++report.unchanged;
      }
    } else {
      check(store.insert(g));
      ++report.inserted;
    }
  }
  if (cloud.sh_degree < store.sh_degree()) check(store.set_sh_degree(cloud.sh_degree));
  for (const ObjectLabel& o : prepared.objects) check(store.set_object(o.id, o.label, o.quality));
  if (prepared.mesh) check(store.set_surface_chunk({0, Epoch{0}, std::move(*prepared.mesh)}));
  if (auto s = store.commit_epoch(); !s) return s.error();
  if (!first_error) return first_error.error();
  return report;
}

Expected<SnapshotApplyReport> apply_snapshot(SceneStore& store, GaussianCloud cloud, bool ids_given,
                                             const IdentityTrackerConfig& identity,
                                             const std::vector<ObjectLabel>& objects, const TriangleMesh* mesh) {
  auto prepared = prepare_snapshot(store, std::move(cloud), ids_given, identity, objects,
                                   mesh ? std::optional<TriangleMesh>(*mesh) : std::nullopt);
  if (!prepared) return prepared.error();
  return commit_snapshot(store, std::move(*prepared));
}

}  // namespace gauss
