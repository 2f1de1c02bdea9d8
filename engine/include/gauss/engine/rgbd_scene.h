#pragma once
// An RGB-D capture served as a scene. Each frame becomes one epoch that (a) adds Gaussians
// seeded from the frame's pixels where the scene has none yet and (b) fuses the frame into
// a TSDF surface whose changed chunks go out in the same epoch.
//
// Seeding is the initialisation RGB-D Gaussian reconstructions start from, without their
// optimisation: one Gaussian per `stride` x `stride` pixel block with valid depth, at the
// block centre's back-projected point, a flat disc on the local surface (normal from the
// neighbouring blocks' points), the block's mean colour, nearly opaque. A block the scene
// already explains adds none: one where an earlier Gaussian's centre, projected into the
// frame, lands (within its own size) at about the block's depth, and that Gaussian is at
// most twice as coarse as the block's own would be. So overlapping frames do not pile up
// layers of the same surface at their depth noise, and a later frame adds what the earlier
// ones did not see, or saw only from much farther away. Its purpose is to let the host serve, and gauss-eval
// evaluate, a real capture whose own frames are the ground truth at their poses; it is not
// a trained model.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <vector>

#include <glm/vec4.hpp>

#include "gauss/engine/codec.h"
#include "gauss/engine/gaussian.h"
#include "gauss/engine/messages.h"
#include "gauss/engine/scene_source.h"
#include "gauss/engine/tsdf.h"

namespace gauss {

struct RgbdSeedConfig {
  std::uint32_t stride{4};     // pixels per block edge, >= 1
  // A block counts as explained by an earlier Gaussian whose depth in this frame is within
  // this share of the block's depth (sensor noise and pose error at room range are ~1-2 %).
  float depth_tolerance{0.05f};
  float min_depth{0.1f};       // depths outside [min, max] (or not finite) are missing
  float max_depth{8.0f};
  float opacity{0.95f};        // in (0, 1)
  // A neighbour block whose depth differs from the centre's by more than this share of the
  // centre depth lies across a depth edge: the normal uses the other side; a block with
  // edges on both sides of an axis is a lone or flying point and is not seeded.
  float max_relative_step{0.05f};
};

// Why `config` is unusable (named field), or Ok.
Status validate(const RgbdSeedConfig& config);

class RgbdSeeder {
 public:
  explicit RgbdSeeder(const RgbdSeedConfig& config) : config_(config) {}
  // The new Gaussians of `frame` (SH degree 0, ids 0: the caller assigns them), remembered
  // for the frames after it. Errors (nothing remembered): a depth or colour buffer of the
  // wrong size, non-positive or non-finite intrinsics, a non-finite pose.
  Expected<std::vector<Gaussian>> seed(const RgbdFrame& frame);
  std::size_t seeded() const { return seeds_.size(); }

 private:
  RgbdSeedConfig config_;
  std::vector<glm::vec4> seeds_;  // every seeded Gaussian: position and in-plane sigma
};

// True when `folder` has the index files of an RGB-D layout rgbd_source.h reads
// (camera-intrinsics.txt; rgb.txt and depth.txt; traj.txt and results/).
bool is_rgbd_capture(const std::filesystem::path& folder);

struct RgbdSceneOptions {
  RgbdSeedConfig seed;
  std::optional<TsdfConfig> surface{TsdfConfig{}};  // nullopt: no fused surface
  double rate_hz{10.0};                             // epochs per second, > 0
};

// (d) The capture's frames in order, one epoch each. A frame that cannot be loaded or used is
// logged and skipped (the store keeps what it had); a frame that seeds nothing and changes no
// surface chunk commits no epoch. Errors: the folder (no frames, bad intrinsics), the
// options, or a capture none of whose frames gave anything (said when it runs out).
Expected<std::unique_ptr<SceneSource>> open_rgbd_capture(const std::filesystem::path& folder,
                                                         const RgbdSceneOptions& options = {}, SourceLog log = {});

// How a capture is served as a scene, found by seeding its frames once without a surface
// (gauss-host and gauss-eval both use it). The codec: fitted to every Gaussian its frames seed
// (all of them are known at the start, unlike a followed folder's snapshots, so nothing need
// clamp). The view a host announces for the capture (scene_view.h): up is capture_up of the
// frames' cameras (scene_up.h: level with their right axes), seen from their mean position;
// the subject, the seeded Gaussians' robust bounds. Frames without a usable pose are left
// out; none left, or no agreed up: +y. Errors: as open_rgbd_capture, or no frame seeds
// anything.
struct CaptureFit {
  CodecParams params;
  msg::SceneView view;
};
Expected<CaptureFit> fit_capture(const std::filesystem::path& folder, const RgbdSceneOptions& options);

}  // namespace gauss
