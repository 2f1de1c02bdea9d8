// Loading a scene file for a viewer, with progress (scene_load.h).
#include "gauss/engine/scene_load.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <new>
#include <system_error>
#include <utility>

#include <glm/common.hpp>

namespace gauss {

std::string_view to_string(SceneLoadPhase phase) {
  switch (phase) {
    case SceneLoadPhase::Reading: return "reading";
    case SceneLoadPhase::Decoding: return "decoding";
    case SceneLoadPhase::Bounds: return "bounds";
    case SceneLoadPhase::Done: return "done";
  }
  return "?";
}

void SceneLoadProgress::start(std::uint64_t bytes_total) noexcept {
  bytes_read_.store(0, std::memory_order_relaxed);
  bytes_total_.store(bytes_total, std::memory_order_relaxed);
  stage_.store(SceneLoadPhase::Reading, std::memory_order_release);
}

SceneLoadPhase SceneLoadProgress::phase() const noexcept {
  const SceneLoadPhase stage = stage_.load(std::memory_order_acquire);
  if (stage != SceneLoadPhase::Reading) return stage;
  const std::uint64_t total = bytes_total_.load(std::memory_order_relaxed);
  return total > 0 && bytes_read_.load(std::memory_order_relaxed) < total ? SceneLoadPhase::Reading
                                                                          : SceneLoadPhase::Decoding;
}

double SceneLoadProgress::read_fraction() const noexcept {
  const std::uint64_t total = bytes_total_.load(std::memory_order_relaxed);
  if (total == 0) return 0.0;
  return std::min(1.0, static_cast<double>(bytes_read_.load(std::memory_order_relaxed)) / static_cast<double>(total));
}

FullBounds full_bounds(std::span<const Gaussian> gaussians) {
  FullBounds out;
  glm::dvec3 lo(INFINITY), hi(-INFINITY);
  for (const Gaussian& g : gaussians) {
    const glm::dvec3 p(g.position);
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
    ++out.finite;
  }
  if (out.finite > 0) {
    out.lo = lo;
    out.hi = hi;
  }
  return out;
}

Expected<LoadedScene> load_scene_file(const std::filesystem::path& path, const std::optional<glm::dvec3>& up_option,
                                      SceneLoadProgress* progress) {
  const auto t0 = std::chrono::steady_clock::now();
  std::error_code ec;
  // A folder (SOG) or a missing file: no size to count; the reader names what is wrong.
  const std::uintmax_t size = std::filesystem::is_regular_file(path, ec) ? std::filesystem::file_size(path, ec) : 0;
  const std::uint64_t total = ec ? 0 : static_cast<std::uint64_t>(size);
  if (progress != nullptr) progress->start(total);
  auto scene = read_splat_file(path, progress != nullptr ? progress->bytes_read() : nullptr);
  if (!scene) return scene.error();
  if (scene->cloud.gaussians.empty()) return Error{path.string() + ": the scene holds no Gaussians"};
  if (progress != nullptr) progress->set_stage(SceneLoadPhase::Bounds);
  LoadedScene out;
  out.path = path;
  out.robust = robust_bounds(scene->cloud.gaussians);
  out.full = full_bounds(scene->cloud.gaussians);
  out.up = choose_scene_up(up_option, path);
  out.file_bytes = total;
  out.scene = std::move(*scene);
  out.load_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

SceneLoadJob::SceneLoadJob(std::filesystem::path path, std::optional<glm::dvec3> up_option) : path_(std::move(path)) {
  thread_ = std::thread([this, up_option] {
    // An exception leaving this thread would end the viewer and the scene it still shows.
    try {
      result_.emplace(load_scene_file(path_, up_option, &progress_));
    } catch (const std::bad_alloc&) {
      result_.emplace(Error{path_.string() + ": not enough memory to load it"});
    }
    progress_.set_stage(SceneLoadPhase::Done);  // release: result_ is complete before done() reads true
  });
}

SceneLoadJob::~SceneLoadJob() {
  if (thread_.joinable()) thread_.join();
}

Expected<LoadedScene> SceneLoadJob::take() {
  if (thread_.joinable()) thread_.join();
  if (!result_) return Error{path_.string() + ": the load's result was already taken"};
  Expected<LoadedScene> out = std::move(*result_);
  result_.reset();
  return out;
}

}  // namespace gauss
