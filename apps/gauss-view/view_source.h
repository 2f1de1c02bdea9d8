#pragma once
// What gauss-view shows: the stream from a host (the shared client runtime), or a scene
// file viewed alone (every Gaussian resident, float values, no host). Both render with
// the same SplatRenderer and frames in flight; the frame loops (windowed, headless) do not
// care which.
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
#include "gauss/engine/scene_up.h"
#include "options.h"

namespace gauss::vk {
class Context;
}

namespace gauss::view {

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
  // cameras.json or the 3DGS default -y (gauss/engine/scene_up.h); for a stream else +y, the
  // up of the host's synthetic rooms and RGB-D fusion.
  const SceneUp& up() const noexcept { return up_; }
  // "host 127.0.0.1:7000" or "scene room.ply (10000 Gaussians)".
  virtual std::string describe() const = 0;

 protected:
  SceneUp up_;
};

// Connects to opts.host (the network thread starts; connecting goes on in the background)
// or loads opts.scene (+ opts.mesh). Errors: a scene or mesh that does not load (the
// loader's message), a renderer that cannot be made.
Expected<std::unique_ptr<ViewSource>> make_view_source(vk::Context& context, const ViewOptions& opts);

}  // namespace gauss::view
