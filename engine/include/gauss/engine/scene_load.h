#pragma once
// Opening a splat scene file for a viewer: the file read (read_splat_file's formats), its
// Gaussians checked, the box the default camera frames, the full box, the scene's up, how
// long it took; on the caller's thread (load_scene_file) or on a thread of its own
// (SceneLoadJob), so that a window keeps drawing while a large file loads.
//
// Progress is what can be counted honestly: the readers parse a whole file image and
// report nothing while they do, so a load counts the bytes read from disk (Reading, a
// fraction of the file's size), then says Decoding with no fraction (the parser), then
// Bounds (robust_bounds' sort, O(n log n)). A SOG folder is read by its own reader: it goes
// straight to Decoding.
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <thread>

#include <glm/vec3.hpp>

#include "gauss/engine/result.h"
#include "gauss/engine/scene_framing.h"
#include "gauss/engine/scene_up.h"
#include "gauss/engine/splat_file.h"

namespace gauss {

enum class SceneLoadPhase : std::uint8_t { Reading, Decoding, Bounds, Done };

// "reading", "decoding", "bounds", "done".
std::string_view to_string(SceneLoadPhase phase);

// Written by the loading thread, read by any other (a progress bar needs no ordering
// beyond done(): the result is complete before it turns true).
class SceneLoadProgress {
 public:
  // Reading while the file's bytes come in, Decoding once they all have (or at once for a
  // SOG folder, whose size is not counted), then Bounds, then Done.
  SceneLoadPhase phase() const noexcept;
  // Reading's fraction of the file read, 0..1 (0 while the size is unknown).
  double read_fraction() const noexcept;
  std::uint64_t bytes_total() const noexcept { return bytes_total_.load(std::memory_order_relaxed); }
  bool done() const noexcept { return stage_.load(std::memory_order_acquire) == SceneLoadPhase::Done; }

  // The loader's side.
  void start(std::uint64_t bytes_total) noexcept;
  std::atomic<std::uint64_t>* bytes_read() noexcept { return &bytes_read_; }
  void set_stage(SceneLoadPhase stage) noexcept { stage_.store(stage, std::memory_order_release); }

 private:
  std::atomic<SceneLoadPhase> stage_{SceneLoadPhase::Reading};  // Reading covers Decoding
  std::atomic<std::uint64_t> bytes_read_{0};
  std::atomic<std::uint64_t> bytes_total_{0};
};

// The box of every finite centre (floaters included), beside the robust box the camera frames.
struct FullBounds {
  glm::dvec3 lo{0.0}, hi{0.0};
  std::size_t finite{0};  // 0: no finite centre, lo = hi = 0
};
FullBounds full_bounds(std::span<const Gaussian> gaussians);

struct LoadedScene {
  std::filesystem::path path;
  SplatScene scene;             // the cloud and the reader's report (format, SH degree)
  RobustBounds robust;          // robust_bounds(): what the default camera frames
  FullBounds full;
  SceneUp up;                   // choose_scene_up(option, path)
  std::uint64_t file_bytes{0};  // bytes read (0 for a SOG folder)
  double load_s{0.0};           // read + decode + bounds, wall clock
};

// Reads `path` (any format read_splat_file reads) and computes its bounds and up, updating
// `progress` when given. Errors: the reader's (naming the path), and a scene with no
// Gaussians (a viewer has nothing to show, so it is refused here rather than by each caller).
// A scene whose centres are all non-finite loads: robust_bounds gives it the unit box.
Expected<LoadedScene> load_scene_file(const std::filesystem::path& path, const std::optional<glm::dvec3>& up_option,
                                      SceneLoadProgress* progress = nullptr);

// load_scene_file on a thread of its own, started by the constructor. The destructor waits
// for the thread (a load cannot be interrupted inside a reader), so dropping a job blocks
// for the rest of its load.
class SceneLoadJob {
 public:
  SceneLoadJob(std::filesystem::path path, std::optional<glm::dvec3> up_option);
  ~SceneLoadJob();
  SceneLoadJob(const SceneLoadJob&) = delete;
  SceneLoadJob& operator=(const SceneLoadJob&) = delete;

  const std::filesystem::path& path() const noexcept { return path_; }
  const SceneLoadProgress& progress() const noexcept { return progress_; }
  // The load has ended (succeeded or failed); take() will not block.
  bool ready() const noexcept { return progress_.done(); }
  // The result; waits for the thread first. Call once.
  Expected<LoadedScene> take();

 private:
  std::filesystem::path path_;
  SceneLoadProgress progress_;
  std::optional<Expected<LoadedScene>> result_;  // written by the thread before phase Done
  std::thread thread_;
};

}  // namespace gauss
