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

// The snapshot's ids (given, or tracked from the scene's), the scene's ids it no longer has
// and how many of its Gaussians are new to the scene.
Status match_ids(SceneStore& store, GaussianCloud& cloud, bool ids_given, const IdentityTrackerConfig& identity,
                 SnapshotApplyReport& report, std::vector<GaussianId>& gone, std::size_t& entering) {
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
    auto r = track_identity(store.gaussians(), cloud.gaussians, identity, [&] { return store.allocate_id(); });
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

Expected<SnapshotApplyReport> apply_snapshot(SceneStore& store, GaussianCloud cloud, bool ids_given,
                                             const IdentityTrackerConfig& identity,
                                             const std::vector<ObjectLabel>& objects, const TriangleMesh* mesh) {
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

  SnapshotApplyReport report;
  std::vector<GaussianId> gone;
  std::size_t entering = 0;
  // The comparison with the scene holds sets of every id: a scene too large for the process
  // is refused here, the store unchanged.
  try {
    if (auto s = match_ids(store, cloud, ids_given, identity, report, gone, entering); !s) return s.error();
  } catch (const std::bad_alloc&) {
    return Error{"apply_snapshot: not enough memory to compare " + std::to_string(cloud.gaussians.size()) +
                 " Gaussians with the scene's " + std::to_string(store.size())};
  }
  if (auto s = store.reserve(store.gaussians().size() + entering); !s) return Error{"apply_snapshot: " + s.message()};

  if (auto s = store.begin_next_epoch(); !s) return s.error();
  // Past validation nothing below should fail; if it does, commit what was applied (the
  // store stays consistent) and report the first error.
  Status first_error = Ok{};
  const auto check = [&](Status s) {
    if (!s && first_error) first_error = std::move(s);
  };
  if (cloud.sh_degree > store.sh_degree()) check(store.set_sh_degree(cloud.sh_degree));
  for (GaussianId id : gone) {
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
  for (const ObjectLabel& o : objects) check(store.set_object(o.id, o.label, o.quality));
  if (mesh) check(store.set_surface_chunk({0, Epoch{0}, *mesh}));
  if (auto s = store.commit_epoch(); !s) return s.error();
  if (!first_error) return first_error.error();
  return report;
}

}  // namespace gauss
