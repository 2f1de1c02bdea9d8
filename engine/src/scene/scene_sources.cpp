// Scene sources: synthetic rooms, snapshot folders (flat or trainer layout), one scene file.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <new>
#include <chrono>
#include <future>
#include <system_error>
#include <tuple>
#include <utility>

#include "gauss/engine/labels_io.h"
#include "gauss/engine/ply_gaussian.h"
#include "gauss/engine/ply_mesh.h"
#include "gauss/engine/scene_source.h"
#include "gauss/engine/splat_file.h"

namespace gauss {

namespace fs = std::filesystem;

void SceneSource::report(const std::string& line) {
  messages_.push_back(line);
  if (log_)
    log_(line);
  else
    std::fprintf(stderr, "gauss scene source: %s\n", line.c_str());
}

namespace {

Status check_rate(double rate_hz) {
  if (!(rate_hz > 0.0 && std::isfinite(rate_hz)))
    return Error{"scene source: rate_hz " + std::to_string(rate_hz) + " must be positive and finite"};
  return Ok{};
}

class SyntheticSource final : public SceneSource {
 public:
  SyntheticSource(SyntheticScene scene, double rate_hz, SourceLog log)
      : SceneSource(std::move(log)), scene_(std::move(scene)), rate_hz_(rate_hz) {}

  Expected<bool> next_epoch(SceneStore& store) override {
    if (scene_.finished()) return false;
    if (auto s = scene_.produce(store); !s) return s.error();
    return true;
  }
  double epoch_period_s() const override { return 1.0 / rate_hz_; }
  std::string describe() const override {
    const auto& c = scene_.config();
    return "synthetic room variant " + std::to_string(c.variant) + ", seed " + std::to_string(c.seed) + ", " +
           std::to_string(c.target_gaussians) + " Gaussians, " + std::to_string(c.epochs) + " epochs";
  }

 private:
  SyntheticScene scene_;
  double rate_hz_;
};

// One snapshot to replay, with its order key.
struct Entry {
  std::int64_t order{0};
  std::string name;  // for ordering ties and messages
  fs::path ply;  // the snapshot's scene file, in any splat format
  std::optional<fs::path> mesh;
  std::optional<fs::path> labels;
  bool operator<(const Entry& o) const { return std::tie(order, name) < std::tie(o.order, o.name); }
};

// The last run of digits in `s` (e.g. "snap_0012" -> 12), or nullopt.
std::optional<std::int64_t> last_number(const std::string& s) {
  std::size_t end = s.size();
  while (end > 0 && !std::isdigit(static_cast<unsigned char>(s[end - 1]))) --end;
  if (end == 0) return std::nullopt;
  std::size_t begin = end;
  while (begin > 0 && std::isdigit(static_cast<unsigned char>(s[begin - 1]))) --begin;
  if (end - begin > 17) return std::nullopt;  // would overflow; order by name instead
  return std::stoll(s.substr(begin, end - begin));
}

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// Scene files a flat snapshot folder lists (detection is by content once listed).
bool is_scene_file_name(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".ply" || ext == ".splat" || ext == ".spz" || ext == ".sog";
}

// Seconds since `p` was last written, or nullopt when it cannot be told.
std::optional<double> seconds_since_write(const fs::path& p) {
  std::error_code ec;
  const auto t = fs::last_write_time(p, ec);
  if (ec) return std::nullopt;
  return std::chrono::duration<double>(fs::file_time_type::clock::now() - t).count();
}

std::optional<fs::path> if_file(const fs::path& p) {
  std::error_code ec;
  if (fs::is_regular_file(p, ec)) return p;
  return std::nullopt;
}

class SnapshotSource final : public SceneSource {
 public:
  SnapshotSource(fs::path root, bool single, SnapshotOptions options, std::vector<ObjectLabel> objects,
                 SourceLog log)
      : SceneSource(std::move(log)),
        root_(std::move(root)),
        single_(single),
        options_(std::move(options)),
        objects_(std::move(objects)) {}

  ~SnapshotSource() override {
    if (job_.valid()) job_.wait();  // it reads the store: done before the source goes
  }

  Expected<bool> next_epoch(SceneStore& store) override {
    if (store.in_epoch()) return Error{"snapshot source: the store has an open epoch"};
    if (options_.prepare_in_background && !single_) return next_epoch_in_background(store);
    std::vector<Entry> entries = list();
    std::optional<Error> last_failure;
    for (const Entry& e : entries) {
      if (consumed_ && !(*consumed_ < e)) continue;
      auto r = load_and_apply(e, store);
      if (r) {
        consumed_ = e;
        ++produced_;
        return true;
      }
      if (!settle_failure(e, r.error(), store, last_failure)) return false;
    }
    if (produced_ == 0 && last_failure) {
      if (single_) return *last_failure;  // the file's own error names it
      return no_usable_snapshot(*last_failure);
    }
    return false;
  }
  double epoch_period_s() const override { return 1.0 / options_.rate_hz; }
  bool busy() const override { return job_.valid(); }
  std::string describe() const override {
    if (single_) return "scene file " + root_.string() + (format_.empty() ? "" : " (" + format_ + ")");
    char rate[32];
    std::snprintf(rate, sizeof rate, "%g", options_.rate_hz);  // "10", not std::to_string's "10.000000"
    return "snapshot folder " + root_.string() + " followed, at most " + rate + " epochs/s";
  }

 private:
  std::vector<Entry> list() {
    std::vector<Entry> out;
    std::error_code ec;
    if (single_) {
      Entry e;
      e.name = root_.filename().string();
      e.ply = root_;
      const std::string stem = root_.stem().string();
      e.mesh = if_file(root_.parent_path() / (stem + "_mesh.ply"));
      e.labels = if_file(root_.parent_path() / (stem + "_labels.txt"));
      out.push_back(std::move(e));
      return out;
    }
    const fs::path trainer = root_ / "point_cloud";
    if (fs::is_directory(trainer, ec)) {
      // 3DGS trainer layout: point_cloud/iteration_N/point_cloud.ply, ordered by N.
      for (const auto& d : fs::directory_iterator(trainer, ec)) {
        const std::string name = d.path().filename().string();
        if (!d.is_directory(ec) || name.rfind("iteration_", 0) != 0) continue;
        const std::string digits = name.substr(10);
        if (digits.empty() || digits.size() > 17 ||
            !std::all_of(digits.begin(), digits.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
          continue;
        const std::optional<std::int64_t> n = std::stoll(digits);
        Entry e;
        e.order = *n;
        e.name = name;
        e.ply = d.path() / "point_cloud.ply";  // a missing file is reported when loaded
        e.mesh = if_file(d.path() / "mesh.ply");
        e.labels = if_file(d.path() / "labels.txt");
        out.push_back(std::move(e));
      }
    } else {
      for (const auto& f : fs::directory_iterator(root_, ec)) {
        const std::string name = f.path().filename().string();
        if (!f.is_regular_file(ec) || !is_scene_file_name(f.path()) || name == "mesh.ply" ||
            ends_with(name, "_mesh.ply"))
          continue;
        Entry e;
        const std::string stem = f.path().stem().string();
        e.order = last_number(stem).value_or(-1);
        e.name = name;
        e.ply = f.path();
        e.mesh = if_file(root_ / (stem + "_mesh.ply"));
        e.labels = if_file(root_ / (stem + "_labels.txt"));
        out.push_back(std::move(e));
      }
    }
    if (ec) report("listing " + root_.string() + ": " + ec.message());
    std::sort(out.begin(), out.end());
    return out;
  }

  // A snapshot read, checked and matched with the scene (prepare_snapshot), not yet committed;
  // what it has to say is said when it is taken up, on the caller's thread.
  struct Prepared {
    Status status{Ok{}};  // the first failure; nothing below counts then
    std::optional<PreparedSnapshot> snapshot;
    std::vector<std::string> before;  // said before the commit, whether it succeeds or not
    std::vector<std::string> notes;   // the reader's notes, said once it is committed
    std::string format;
    std::optional<fs::path> mesh_path;  // the mesh it carries
  };

  // A failure to load `e`: a folder's file written within the settle time may be one a
  // trainer is still writing, so it is tried again (false: stop looking now); anything else
  // is skipped and noted in `failure` (true: go on with the next).
  bool settle_failure(const Entry& e, const Error& error, const SceneStore& store, std::optional<Error>& failure) {
    const std::optional<double> age = single_ ? std::nullopt : age_of(e);
    if (age && *age < options_.settle_s) {
      if (waiting_for_ != e.ply) report("waiting for " + e.ply.string() + " (" + error.message + "; still being written?)");
      waiting_for_ = e.ply;
      return false;
    }
    consumed_ = e;
    if (!single_)  // a scene file alone is not skipped: its error is the source's
      report("skipped snapshot " + e.ply.string() + ": " + error.message + " (the store keeps epoch " +
             std::to_string(to_underlying(store.epoch())) + ")");
    failure = error;
    return true;
  }

  Error no_usable_snapshot(const Error& last) const {
    return Error{"snapshot folder " + root_.string() + ": no usable snapshot; last error: " + last.message};
  }

  // One snapshot a call: the first call starts preparing the next entry on a thread and
  // returns false, a later one commits it once it is ready (or says why it was not).
  Expected<bool> next_epoch_in_background(SceneStore& store) {
    if (job_.valid()) {
      if (job_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return false;
      Prepared p = job_.get();
      const Entry e = std::move(job_entry_);
      Status r = p.status;
      if (r && p.snapshot->against != store.epoch()) {
        r = load_and_apply(e, store);  // the store moved on meanwhile: prepared again, here
      } else if (r) {
        r = commit(std::move(p), store);
      } else {
        say(p.before);
      }
      if (r) {
        consumed_ = e;
        ++produced_;
        return true;
      }
      if (!settle_failure(e, r.error(), store, background_failure_)) return false;
    }
    for (const Entry& e : list()) {
      if (consumed_ && !(*consumed_ < e)) continue;
      job_entry_ = e;
      // The thread reads the store (identity tracking) while the caller's thread serves
      // from it; nothing changes it until the commit (see prepare_in_background).
      const SceneStore* scene = &store;
      const fs::path last_mesh = last_mesh_;
      try {
        job_ = std::async(std::launch::async, [this, e, scene, last_mesh] { return read_and_prepare(e, *scene, last_mesh); });
        return false;
      } catch (const std::system_error&) {
        // No thread to be had: read here, as without prepare_in_background.
      }
      if (Status r = load_and_apply(e, store); r) {
        consumed_ = e;
        ++produced_;
        return true;
      } else if (!settle_failure(e, r.error(), store, background_failure_)) {
        return false;
      }
    }
    if (produced_ == 0 && background_failure_) {
      const Error last = *std::exchange(background_failure_, std::nullopt);
      return no_usable_snapshot(last);  // said once, as a call that tried them all says it
    }
    return false;
  }

  Status load_and_apply(const Entry& e, SceneStore& store) {
    Prepared p = read_and_prepare(e, store, last_mesh_);
    if (!p.status) {
      say(p.before);
      return p.status;
    }
    return commit(std::move(p), store);
  }

  void say(const std::vector<std::string>& lines) {
    for (const std::string& line : lines) report(line);
  }

  // Reads `e` and prepares it against the store as it stands; reads the source's options only
  // (a background job runs it).
  Prepared read_and_prepare(const Entry& e, const SceneStore& store, const fs::path& last_mesh) const {
    // A snapshot that does not fit in memory is skipped like a broken one: reading it and
    // comparing it with the scene come before the store changes (prepare_snapshot), and the
    // store's own room is asked for before its epoch opens (SceneStore::reserve).
    Prepared p;
    try {
      p.status = read_into(e, store, last_mesh, p);
    } catch (const std::bad_alloc&) {
      p.snapshot.reset();
      p.status = Error{"not enough memory to read " + e.ply.string() + " and compare it with the scene's " +
                       std::to_string(store.size()) + " Gaussians"};
    }
    return p;
  }

  Status read_into(const Entry& e, const SceneStore& store, const fs::path& last_mesh, Prepared& p) const {
    auto scene = read_splat_file(e.ply);
    if (!scene) return scene.error();
    const std::size_t dropped = scene->report.dropped.size(), total = scene->report.count + dropped;
    if (!single_ && store.size() > 0 && double(dropped) > options_.max_non_finite_fraction * double(total))
      return Error{std::to_string(dropped) + " of its " + std::to_string(total) +
                   " Gaussians hold a NaN or Inf (the trainer diverged?), the first: " + scene->report.first_dropped};
    p.format = std::string(to_string(scene->report.format));
    GaussianCloud cloud = std::move(scene->cloud);
    const std::optional<fs::path> labels_path = options_.labels ? options_.labels : e.labels;
    if (labels_path) {
      auto labels = read_labels(*labels_path);
      if (!labels) return labels.error();
      if (auto s = apply_labels(cloud, *labels, options_.label_zero_is_unlabelled, labels_path->string(),
                                e.ply.string(), scene->report.dropped);
          !s)
        return s;
      if (scene->report.has_object_id)
        p.before.push_back(e.ply.string() + ": object_id property overridden by labels " + labels_path->string());
    }
    // Surface: the snapshot's own mesh, else the folder's mesh.ply; applied when it changes.
    std::optional<fs::path> mesh_path = options_.snapshot_meshes ? e.mesh : std::nullopt;
    if (!mesh_path && !single_ && options_.snapshot_meshes) mesh_path = if_file(root_ / "mesh.ply");
    if (options_.mesh) mesh_path = options_.mesh;
    std::optional<TriangleMesh> mesh;
    if (mesh_path && *mesh_path != last_mesh) {
      auto m = read_mesh_ply(*mesh_path);
      if (m) {
        mesh = std::move(m->mesh);
        p.mesh_path = mesh_path;
      } else {
        p.before.push_back("ignored mesh " + mesh_path->string() + ": " + m.message() + " (Gaussians still applied)");
      }
    }
    auto prepared = prepare_snapshot(store, std::move(cloud), scene->report.has_gaussian_id, options_.identity,
                                     objects_, std::move(mesh));
    if (!prepared) return prepared.error();
    p.snapshot = std::move(*prepared);
    for (const std::string& note : splat_load_notes(scene->report)) p.notes.push_back(e.ply.string() + ": " + note);
    return Ok{};
  }

  Status commit(Prepared p, SceneStore& store) {
    say(p.before);
    auto applied = commit_snapshot(store, std::move(*p.snapshot));
    if (!applied) return applied.error();
    if (p.mesh_path) last_mesh_ = *p.mesh_path;
    format_ = std::move(p.format);
    last_report_ = *applied;
    say(p.notes);
    return Ok{};
  }

  // Seconds since the entry was last written: its file's, or, while a trainer's iteration
  // folder has no file yet (it makes the folder, then writes the file into it), the folder's.
  std::optional<double> age_of(const Entry& e) const {
    if (const auto age = seconds_since_write(e.ply)) return age;
    const fs::path dir = e.ply.parent_path();
    if (dir == root_) return std::nullopt;
    return seconds_since_write(dir);
  }

  fs::path root_;
  bool single_;
  SnapshotOptions options_;
  std::vector<ObjectLabel> objects_;
  std::optional<Entry> consumed_;  // the last entry tried (good or bad)
  std::size_t produced_{0};
  fs::path last_mesh_;
  fs::path waiting_for_;  // the snapshot last reported as still being written
  std::string format_;    // of the last snapshot read
  SnapshotApplyReport last_report_;
  // prepare_in_background: the snapshot being prepared and its entry, and a failure not yet
  // said as "no usable snapshot".
  std::future<Prepared> job_;
  Entry job_entry_;
  std::optional<Error> background_failure_;
};

Expected<std::vector<ObjectLabel>> load_objects(const fs::path& root, const SnapshotOptions& options) {
  if (options.objects_json) return read_objects_json(*options.objects_json);
  if (auto p = if_file(root / "objects.json")) return read_objects_json(*p);
  return std::vector<ObjectLabel>{};
}

}  // namespace

Expected<std::unique_ptr<SceneSource>> open_synthetic_source(const SyntheticSourceOptions& options, SourceLog log) {
  if (auto s = check_rate(options.rate_hz); !s) return s.error();
  auto scene = SyntheticScene::create(options.scene);
  if (!scene) return scene.error();
  return std::unique_ptr<SceneSource>(
      std::make_unique<SyntheticSource>(std::move(scene).value(), options.rate_hz, std::move(log)));
}

Expected<std::unique_ptr<SceneSource>> open_snapshot_folder(const fs::path& folder, const SnapshotOptions& options,
                                                            SourceLog log) {
  if (auto s = check_rate(options.rate_hz); !s) return s.error();
  if (!(options.max_non_finite_fraction >= 0.0 && options.max_non_finite_fraction <= 1.0))
    return Error{"snapshot folder: max_non_finite_fraction " + std::to_string(options.max_non_finite_fraction) +
                 " is outside 0..1"};
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) return Error{"snapshot folder " + folder.string() + " is not a directory"};
  auto objects = load_objects(folder, options);
  if (!objects) return objects.error();
  return std::unique_ptr<SceneSource>(
      std::make_unique<SnapshotSource>(folder, false, options, std::move(objects).value(), std::move(log)));
}

bool is_snapshot_folder(const fs::path& path) {
  std::error_code ec;
  return fs::is_directory(path, ec) && !fs::is_regular_file(path / "meta.json", ec);
}

Expected<std::unique_ptr<SceneSource>> open_scene_file(const fs::path& ply, const SnapshotOptions& options,
                                                       SourceLog log) {
  if (auto s = check_rate(options.rate_hz); !s) return s.error();
  std::error_code ec;
  // A SOG scene may be a folder of its files.
  if (!fs::is_regular_file(ply, ec) && !fs::is_regular_file(ply / "meta.json", ec))
    return Error{"scene file " + ply.string() + " is not a regular file (nor a SOG folder with meta.json)"};
  std::vector<ObjectLabel> objects;
  if (options.objects_json) {
    auto o = read_objects_json(*options.objects_json);
    if (!o) return o.error();
    objects = std::move(o).value();
  }
  return std::unique_ptr<SceneSource>(
      std::make_unique<SnapshotSource>(ply, true, options, std::move(objects), std::move(log)));
}

}  // namespace gauss
