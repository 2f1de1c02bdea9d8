#pragma once
// What gauss-host serves, behind one interface:
//   - synthetic:VARIANT: the embedded evolving room, its surface fused into a TSDF from
//     each epoch's exact ground-truth depth (the scene's own cameras);
//   - a scene file (any splat format, one epoch) or a snapshot folder (each new snapshot
//     an epoch, followed live while a trainer writes it), through engine SceneSources,
//     with an optional fixed surface (--mesh) or one fused once from an RGB-D capture
//     (--rgbd);
//   - an RGB-D capture: its frames replayed as epochs, each adding Gaussians seeded from its
//     pixels and fusing its depth into the surface (engine rgbd_scene.h).
// open() commits the first epoch (a folder without a snapshot yet is waited for), so the
// codec can be fitted to real content before any client is served.
#include <atomic>
#include <memory>
#include <optional>
#include <string>

#include "gauss/engine/codec.h"
#include "gauss/engine/messages.h"
#include "gauss/engine/result.h"
#include "gauss/engine/scene_source.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/synthetic_scene.h"
#include "gauss/engine/tsdf.h"
#include "options.h"

namespace gauss::host_app {

class SceneFeed {
 public:
  // `stop` ends a wait for a folder's first snapshot (Ctrl-C): then an error says so.
  static Expected<std::unique_ptr<SceneFeed>> open(const Options& options, SceneStore& store,
                                                   const std::atomic<bool>& stop);

  // Commits the next epoch when one is due at `now` (seconds since start): true when it did.
  Expected<bool> step(SceneStore& store, double now);
  // Codec parameters fitted to the first epoch (synthetic: the room box, SH degree 1).
  const CodecParams& codec_params() const { return params_; }
  // How clients first look at it (SceneInfo::view): up, the subject's box, the capture's side.
  const msg::SceneView& view() const { return view_; }
  std::string describe() const;
  // Whether more epochs may still come (a followed folder always may).
  bool live() const;
  // Lines the scene source logged (skipped or awaited snapshots), since the last call.
  std::vector<std::string> take_messages();

 private:
  SceneFeed() = default;
  static Expected<std::unique_ptr<SceneFeed>> open_capture(const Options& options, SceneStore& store);
  Status fuse_rgbd(const Options& options, SceneStore& store);
  Status synthetic_surface(SceneStore& store);
  Expected<bool> step_epoch(SceneStore& store, double now);

  std::optional<SyntheticScene> synthetic_;
  std::optional<TsdfVolume> surface_;  // synthetic: fused per epoch
  std::unique_ptr<SceneSource> source_;
  bool folder_{false};
  bool capture_{false};  // an RGB-D capture: exhausted when its frames run out
  bool exhausted_{false};
  double period_s_{0.1};
  double next_epoch_{0.0};
  std::size_t messages_taken_{0};
  CodecParams params_;
  msg::SceneView view_;
  std::string surface_note_;
  std::string view_note_;  // where the up came from, for describe()
};

}  // namespace gauss::host_app
