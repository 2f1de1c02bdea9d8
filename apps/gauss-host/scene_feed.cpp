#include "scene_feed.h"

#include <chrono>
#include <cstdio>
#include <new>
#include <system_error>
#include <thread>

#include "gauss/engine/ply_mesh.h"
#include "gauss/engine/rgbd_scene.h"
#include "gauss/engine/rgbd_source.h"
#include "gauss/engine/scene_up.h"
#include "gauss/engine/scene_view.h"
#include "gauss/engine/system_memory.h"
#include "status_line.h"

namespace gauss::host_app {

namespace fs = std::filesystem;

namespace {

Expected<TsdfVolume> make_volume(double voxel_m) {
  TsdfConfig tc;
  tc.voxel_size = static_cast<float>(voxel_m);
  return TsdfVolume::create(tc);
}

// The capture's seeding and surface as the options say (gauss-eval builds the same).
RgbdSceneOptions capture_options(const Options& o) {
  RgbdSceneOptions r;
  r.seed.stride = o.rgbd_stride;
  if (o.surface_voxel > 0.0)
    r.surface->voxel_size = static_cast<float>(o.surface_voxel);
  else
    r.surface.reset();
  r.rate_hz = o.epoch_period_s > 0.0 ? 1.0 / o.epoch_period_s : 1e6;
  return r;
}

}  // namespace

Expected<std::unique_ptr<SceneFeed>> SceneFeed::open(const Options& o, SceneStore& store,
                                                     const std::atomic<bool>& stop) {
  std::unique_ptr<SceneFeed> feed(new SceneFeed());
  feed->period_s_ = o.epoch_period_s;
  if (!o.scene_path) {
    if (o.labels || o.objects || o.rgbd || o.mesh || o.up)
      return Error{"--labels, --objects, --rgbd, --mesh and --up apply to scene files and folders, not to synthetic:" +
                   std::to_string(o.variant) + " (it has its own objects and surface, and is y up)"};
    SyntheticSceneConfig sc;
    sc.variant = o.variant;
    sc.seed = o.seed;
    sc.target_gaussians = o.gaussians;
    sc.epochs = o.epochs;
    auto scene = SyntheticScene::create(sc);
    if (!scene) return scene.error();
    feed->synthetic_.emplace(std::move(*scene));
    if (o.surface_voxel > 0.0) {
      auto v = make_volume(o.surface_voxel);
      if (!v) return v.error();
      feed->surface_.emplace(std::move(*v));
    }
    // The codec box must cover every Gaussian the scene will ever hold: the room plus a
    // margin for the noisy first observations.
    feed->params_.sh_degree = 1;
    feed->params_.box.min = feed->synthetic_->room_min() - glm::vec3(0.5f);
    feed->params_.box.max = feed->synthetic_->room_max() + glm::vec3(0.5f);
    feed->view_ = room_view(feed->synthetic_->room_min(), feed->synthetic_->room_max());
    if (auto r = feed->step(store, 0.0); !r) return r.error();
    return feed;
  }

  const fs::path& path = *o.scene_path;
  if (is_rgbd_capture(path)) return open_capture(o, store);
  if (o.rgbd && o.mesh) return Error{"--rgbd and --mesh both give the surface: choose one"};
  SnapshotOptions so;
  so.rate_hz = o.epoch_period_s > 0.0 ? 1.0 / o.epoch_period_s : 1e6;
  so.settle_s = o.settle_s;
  so.labels = o.labels;
  so.objects_json = o.objects;
  so.mesh = o.mesh;
  so.snapshot_meshes = !o.rgbd;
  if (o.mesh) {
    auto m = read_mesh_ply(*o.mesh);  // said now, not as a line per snapshot
    if (!m) return Error{"--mesh: " + m.message()};
  }
  SourceLog quiet_log = [](const std::string&) {};  // lines are printed by the host loop
  feed->folder_ = is_snapshot_folder(path);
  // A followed folder's snapshots are read and matched off the serving thread: at a million
  // Gaussians that took the host 4-6 s a snapshot, in which no client was answered. The
  // feed is the store's only writer, as the background reading requires.
  so.prepare_in_background = feed->folder_;
  auto source = feed->folder_ ? open_snapshot_folder(path, so, quiet_log) : open_scene_file(path, so, quiet_log);
  if (!source) return source.error();
  feed->source_ = std::move(*source);

  // The first epoch: a folder a trainer has not written into yet is waited for.
  bool said_waiting = false;
  for (;;) {
    auto r = feed->source_->next_epoch(store);
    if (!r) return r.error();
    if (*r) break;
    if (!feed->folder_) return Error{"scene " + path.string() + " gave no epoch"};
    if (stop.load()) return Error{"stopped while waiting for the first snapshot in " + path.string()};
    if (!said_waiting && !feed->source_->busy()) {
      std::printf("gauss-host: waiting for the first snapshot in %s\n", path.string().c_str());
      std::fflush(stdout);
      said_waiting = true;
    }
    for (const std::string& line : feed->take_messages()) std::printf("gauss-host: %s\n", line.c_str());
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  // A followed folder's later snapshots may reach beyond the first one's bounds.
  feed->params_ = feed->folder_ ? fit_live_codec_params(store.gaussians(), store.sh_degree())
                                : fit_codec_params(store.gaussians(), store.sh_degree());
  // Which way is up, as a local viewer of the file would decide.
  const SceneUp up = choose_scene_up(o.up, path);
  if (!up.problem.empty())
    std::printf("gauss-host: %s; up is %s, %s\n", up.problem.c_str(), up_label(up.up).c_str(), up.detail.c_str());
  feed->view_ = capture_view(store.gaussians(), up.up, up.capture_position);
  feed->view_note_ = "up " + up_label(up.up) + " (" + up.detail + ")";
  if (o.rgbd)
    if (auto s = feed->fuse_rgbd(o, store); !s) return s.error();
  if (o.mesh) feed->surface_note_ = "surface " + o.mesh->string();
  return feed;
}

// An RGB-D capture as the scene: its first frame that gives anything is committed now, the
// rest one per epoch period. The codec is fitted to all the Gaussians its frames will seed
// (a dry run of the seeding), so later frames looking elsewhere in the room do not clamp.
Expected<std::unique_ptr<SceneFeed>> SceneFeed::open_capture(const Options& o, SceneStore& store) {
  if (o.labels || o.objects || o.rgbd || o.mesh)
    return Error{"--labels, --objects, --rgbd and --mesh do not apply to an RGB-D capture as the scene (" +
                 o.scene_path->string() + "): it has no labels and fuses its own surface"};
  std::unique_ptr<SceneFeed> feed(new SceneFeed());
  feed->period_s_ = o.epoch_period_s;
  feed->folder_ = true;  // followed until its frames run out, then exhausted
  feed->capture_ = true;
  auto source = open_rgbd_capture(*o.scene_path, capture_options(o), [](const std::string&) {});
  if (!source) return source.error();
  feed->source_ = std::move(*source);
  auto first = feed->source_->next_epoch(store);
  if (!first) return first.error();
  if (!*first) return Error{"RGB-D capture " + o.scene_path->string() + " gave no epoch"};
  auto fit = fit_capture(*o.scene_path, capture_options(o));
  if (!fit) return fit.error();
  feed->params_ = fit->params;
  feed->view_ = fit->view;
  if (o.up) feed->view_.up = glm::vec3(*o.up);
  feed->view_note_ = "up " + up_label(glm::dvec3(feed->view_.up)) + (o.up ? " (--up)" : " (its cameras)");
  return feed;
}

// Fuses every frame of the capture once, then commits the surface in its own epoch.
Status SceneFeed::fuse_rgbd(const Options& o, SceneStore& store) {
  auto capture = RgbdFolderSource::open(*o.rgbd);
  if (!capture) return Error{"--rgbd: " + capture.message()};
  auto volume = make_volume(o.surface_voxel > 0.0 ? o.surface_voxel : 0.02);
  if (!volume) return volume.error();
  apps::StatusLine status;
  std::size_t fused = 0, skipped = 0;
  for (std::size_t i = 0; i < capture->frame_count(); ++i) {
    status.update("gauss-host: fusing " + o.rgbd->string() + " frame " + std::to_string(i + 1) + "/" +
                  std::to_string(capture->frame_count()));
    auto frame = capture->load(i, store.epoch());
    Status s = frame ? volume->integrate(*frame) : Status{frame.error()};
    if (!s) {
      ++skipped;
      std::fprintf(stderr, "gauss-host: --rgbd frame %s skipped: %s\n", capture->frame_name(i).c_str(),
                   s.message().c_str());
      continue;
    }
    ++fused;
  }
  status.done({});
  if (fused == 0) return Error{"--rgbd: no frame of " + o.rgbd->string() + " could be fused"};
  const auto edits = volume->extract_changed();
  Status s = store.begin_next_epoch();
  if (s) s = apply_surface_edits(store, edits);
  if (s) s = store.commit_epoch();
  if (!s) return Error{"--rgbd: committing the surface: " + s.message()};
  surface_note_ = "surface fused from " + std::to_string(fused) + " " + rgbd_layout_name(capture->layout()) +
                  " frames (" + std::to_string(edits.size()) + " chunks" +
                  (skipped ? ", " + std::to_string(skipped) + " frames skipped" : std::string{}) + ")";
  return Ok{};
}

// The synthetic scene's epoch frames (exact depth) fused; the changed chunks enter the
// store in the following epoch.
Status SceneFeed::synthetic_surface(SceneStore& store) {
  if (!surface_) return Ok{};
  for (const Camera& cam : synthetic_->cameras_of_epoch(synthetic_->produced() - 1))
    if (auto s = surface_->integrate(synthetic_rgbd_frame(*synthetic_, cam, store.epoch())); !s)
      std::fprintf(stderr, "gauss-host: surface frame skipped: %s\n", s.message().c_str());
  const auto edits = surface_->extract_changed();
  if (edits.empty()) return Ok{};
  Status s = store.begin_next_epoch();
  if (s) s = apply_surface_edits(store, edits);
  if (s) s = store.commit_epoch();
  if (!s) return Error{"surface epoch failed: " + s.message()};
  return Ok{};
}

Expected<bool> SceneFeed::step(SceneStore& store, double now) {
  // A snapshot too large is refused before the store changes (SceneStore::reserve) and
  // skipped; memory running out anywhere else mid-epoch leaves nothing consistent to serve,
  // so the host ends with the figures (closing its clients and writing its records) instead
  // of on std::terminate.
  try {
    return step_epoch(store, now);
  } catch (const std::bad_alloc&) {
    const auto headroom = memory_headroom();
    return Error{"out of memory in epoch " + std::to_string(to_underlying(store.epoch()) + 1) + " with " +
                 std::to_string(store.size()) + " Gaussians in the scene" +
                 (headroom ? "; " + headroom->text() : std::string{})};
  }
}

Expected<bool> SceneFeed::step_epoch(SceneStore& store, double now) {
  // A snapshot being prepared in the background is asked after at every step, so that it is
  // served once ready rather than an epoch period later.
  const bool preparing = source_ && source_->busy();
  if ((now < next_epoch_ && !preparing) || exhausted_) return false;
  if (!preparing) next_epoch_ = now + period_s_;
  if (synthetic_) {
    if (synthetic_->finished()) {
      exhausted_ = true;
      return false;
    }
    if (auto s = synthetic_->produce(store); !s) return Error{"epoch failed: " + s.message()};
    if (auto s = synthetic_surface(store); !s) return s.error();
    return true;
  }
  auto r = source_->next_epoch(store);
  if (!r) return r.error();
  // A file is one epoch and a capture's frames are all listed at the start; a folder may grow.
  if (!*r && (!folder_ || capture_)) exhausted_ = true;
  return *r;
}

std::string SceneFeed::describe() const {
  std::string d = synthetic_ ? "synthetic:" + std::to_string(synthetic_->config().variant) + " (" +
                                   std::to_string(synthetic_->config().target_gaussians) + " Gaussians, " +
                                   std::to_string(synthetic_->config().epochs) + " epochs)"
                             : source_->describe();
  if (!surface_note_.empty()) d += ", " + surface_note_;
  if (!view_note_.empty()) d += ", " + view_note_;
  return d;
}

bool SceneFeed::live() const { return !exhausted_; }

std::vector<std::string> SceneFeed::take_messages() {
  if (!source_) return {};
  const auto& all = source_->messages();
  std::vector<std::string> out(all.begin() + static_cast<std::ptrdiff_t>(messages_taken_), all.end());
  messages_taken_ = all.size();
  return out;
}

}  // namespace gauss::host_app
