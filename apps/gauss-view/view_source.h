#pragma once
// What gauss-view shows: the stream from a host (the shared client runtime), or a scene
// file viewed alone (every Gaussian resident, float values, no host). Both render with
// the same SplatRenderer and frames in flight; the frame loops (windowed, headless) do not
// care which.
#include <filesystem>
#include <memory>
#include <optional>
#include <utility>
#include <span>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/client/client_runtime.h"
#include "gauss/engine/result.h"
#include "gauss/engine/scene_framing.h"
#include "gauss/engine/scene_load.h"
#include "gauss/engine/messages.h"
#include "gauss/engine/scene_up.h"
#include "options.h"

namespace gauss::vk {
class Context;
}

namespace gauss::view {

// What the scene panel shows of a local scene (a stream has none: its panels show the stream).
struct SceneSummary {
  std::filesystem::path path;
  SplatFormat format{SplatFormat::InriaPly};
  std::size_t gaussians{0};       // in the file
  std::uint64_t skipped{0};       // non-finite Gaussians not drawn (left out by the reader, or refused by the renderer)
  int sh_degree{0};
  RobustBounds robust;            // the box the default camera frames
  FullBounds full;                // every finite centre
  std::uint64_t file_bytes{0};
  double load_s{0.0};             // read + decode + bounds (scene_load.h)
  double upload_s{0.0};           // renderer made and every Gaussian staged for the GPU
  // GPU memory: the resident set (occupied slots x the renderer's bytes per slot: every
  // per-slot buffer, SH included) and everything the renderer allocated (sort buffers,
  // targets; memory_plan().total_bytes). No CPU copy is kept after the upload.
  std::uint64_t resident_bytes{0};
  std::uint64_t renderer_bytes{0};
};

class ViewSource {
 public:
  virtual ~ViewSource() = default;
  // One display frame of 1 or 2 views (see ClientRuntime::frame).
  virtual Expected<client::DisplayFrameStats> frame(std::span<const Camera> views,
                                                    const render::FrameHooks& hooks = {}) = 0;
  virtual std::vector<client::GpuFrameStats> take_gpu_stats() = 0;
  virtual Status wait_frames() = 0;
  virtual render::SplatRenderer& renderer() = 0;
  // The streaming client, or nullptr for a local scene.
  virtual client::ClientRuntime* runtime() noexcept { return nullptr; }
  // Nothing is left to do: for a stream, connected, nothing pending, something resident,
  // and no edit arrived for `quiet_s` seconds; a local scene is always settled.
  virtual bool settled(double quiet_s) = 0;
  // The box the default camera frames: for a local scene the opacity-weighted 2nd..98th
  // percentile box of the Gaussian centres (floaters ignored, gauss/engine/scene_framing.h);
  // nullopt for a stream (its SceneInfo's box arrives later).
  virtual std::optional<RobustBounds> bounds() const { return std::nullopt; }
  // The scene's up and where it came from: --up; for a local scene else its trainer's
  // cameras.json or the 3DGS default -y (gauss/engine/scene_up.h); for a stream else the up
  // its host announces (take_host_view), +y until then.
  const SceneUp& up() const noexcept { return up_; }
  // A stream's view as its host announced it (SceneInfo::view), once its SceneInfo has
  // arrived, and the source's up becomes the host's unless --up set it. Never waits (a
  // publication step may hold the state). nullopt for a local scene, or before SceneInfo.
  virtual std::optional<msg::SceneView> take_host_view() { return std::nullopt; }
  // The view take_host_view() last returned (for the panels); nullopt before it did.
  virtual std::optional<msg::SceneView> host_view() const { return std::nullopt; }
  // "host 127.0.0.1:7000" or "scene room.ply (10000 Gaussians)".
  virtual std::string describe() const = 0;
  // A local scene's figures (the scene panel); nullptr for a stream.
  virtual const SceneSummary* summary() const noexcept { return nullptr; }

 protected:
  SceneUp up_;
};

// Connects to opts.host (the network thread starts; connecting goes on in the background)
// or loads opts.scene (+ opts.mesh) through load_scene_file and make_local_source. Errors: a
// scene or mesh that does not load (the loader's message), a renderer that cannot be made.
Expected<std::unique_ptr<ViewSource>> make_view_source(vk::Context& context, const ViewOptions& opts);

// A local scene from a loaded file (scene_load.h): a renderer sized for it (opts: frames in
// flight, window or headless size) with every Gaussian written, and `mesh` when not empty.
// On the calling thread: it records GPU uploads. Errors: a renderer the device cannot hold,
// an upload or mesh that fails; nothing is left allocated then.
Expected<std::unique_ptr<ViewSource>> make_local_source(vk::Context& context, const ViewOptions& opts,
                                                        LoadedScene scene, const std::filesystem::path& mesh = {});

}  // namespace gauss::view
