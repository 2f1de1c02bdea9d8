#pragma once
// The scenes gauss-eval serves, with the codec the host streams them with and the cameras
// the evaluation looks from:
//   - a synthetic room, produced epoch by epoch up to the configured count and then held
//     still, with its exact ground truth (colour, depth and object ids for any camera);
//   - a scene file (any splat format the host reads, with optional labels / objects JSON),
//     one epoch, without ground truth: its cameras orbit the scene's central box;
//   - a snapshot folder (as gauss-host follows one): every snapshot committed in order, the
//     evaluation looks at the last, and the model-edit latencies replay them as epochs;
//   - an RGB-D capture (as gauss-host serves one: Gaussians seeded from its frames, one epoch
//     per frame): its cameras are the capture's own, and its frames, downsampled to the
//     evaluation size, are the ground truth at exactly those cameras (no other view has any).
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/camera.h"
#include "gauss/engine/codec.h"
#include "gauss/engine/query.h"
#include "gauss/engine/result.h"
#include "gauss/engine/rgbd_scene.h"
#include "gauss/engine/scene_source.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/synthetic_scene.h"
#include "options.h"

namespace gauss::eval_app {

struct EvalScene {
  std::string name;  // "room<variant>", or the scene file's name
  int variant{-1};   // the synthetic room, or -1 for a scene file
  std::string source;  // the scene file or snapshot folder as given (empty for a room)
  int snapshots{0};    // epochs a snapshot folder or RGB-D capture committed; 0 otherwise
  bool capture{false};  // an RGB-D capture
  std::unique_ptr<SyntheticScene> synthetic;  // null for a scene file: no ground truth
  // Where viewpoints may go: the room's interior, or for a scene file the box of its
  // central 96 % (per axis), whose centre the orbit cameras look at.
  glm::dvec3 region_min{0.0}, region_max{0.0};
  glm::dvec3 up{0.0, 1.0, 0.0};  // the scene's up direction (a room's +y; a file's as gauss-host decides it)
  std::string up_from;            // where a file's or capture's up came from, for the report (empty: a room)
  std::unique_ptr<SceneStore> store;  // held still during the evaluation
  CodecParams codec;
  std::size_t appearance{0};          // Gaussians that can be resident (carriers excluded)
  std::vector<Camera> cameras;        // the fidelity cameras (from the room's trajectory)
  // An RGB-D capture's ground truth: the frame behind each of `cameras`, same order.
  std::vector<GroundTruthImage> capture_truth;
  std::vector<std::string> capture_frames;  // their frame names
};

// How gauss-host seeds and fuses an RGB-D capture for these options (--rgbd-stride,
// --rgbd-cell, --surface fused at kCaptureSurfaceVoxel).
inline constexpr double kCaptureSurfaceVoxel = 0.04;  // gauss-host's --surface-voxel default
RgbdSceneOptions capture_options(const Options& options);

// Produces room `variant` as the options say. Errors: the scene config (named field).
Expected<EvalScene> make_scene(const Options& options, int variant);
// Reads options.scene_file (with options.labels / options.objects) as the host would serve
// it: one epoch, the codec fitted to it. Cameras: options.cameras on a circle around the
// central box's centre, 20 degrees above its horizon (options.up), at 1.8 times the box's
// half diagonal, so the box fills most of the view; up as gauss-host takes it (choose_scene_up:
// --up, else a trainer cameras.json beside the scene, else -y). Errors: the file, labels or
// objects (named), an empty scene.
// A snapshot folder: every snapshot committed in order (identity tracked as the host
// does), the codec fitted to the first as the host fits it (fit_live_codec_params), the
// cameras to the last; errors name the folder or snapshot.
// An RGB-D capture: every frame committed as the host does, the codec as the host fits it
// (fit_capture); cameras: options.cameras of its frames evenly spread (those that load), at
// the evaluation size, which must divide the frames' size by one whole factor; up: the one
// gauss-host announces for it (fit_capture: level with every frame's right axis; --up is
// ignored). Errors: the capture, a size it does not divide, a frame without colour.
Expected<EvalScene> make_file_scene(const Options& options);
Expected<EvalScene> make_capture_scene(const Options& options);  // the capture case of make_file_scene

// The epochs of a scene one at a time, as a host receives them: a room's trajectory, a
// snapshot folder's snapshots or a capture's frames. For the model-edit latencies.
class EpochFeed {
 public:
  // Errors: a scene of one epoch (a scene file), or the source (named).
  static Expected<EpochFeed> open(const EvalScene& scene, const Options& options);
  Status produce(SceneStore& store);  // commits the next epoch
  bool finished() const;
  int produced() const noexcept { return produced_; }
  int total() const noexcept { return total_; }

 private:
  std::optional<SyntheticScene> synthetic_;
  std::shared_ptr<SceneSource> folder_;
  int produced_{0}, total_{0};
};

// `a` moved by a standing user's head sway `t` seconds into a flicker window: a few cm
// side to side and back and forth, a few degrees of yaw, at 0.2-0.45 Hz.
Camera swayed(const Camera& a, double t);

// A pinhole camera at `eye` looking at `target` (`up` up), with the trajectory's focal
// ratio (fx = 0.75 width: about 67 degrees across).
Camera look_camera(const glm::dvec3& eye, const glm::dvec3& target, std::uint32_t width, std::uint32_t height,
                   const glm::dvec3& up = glm::dvec3(0.0, 1.0, 0.0));

// The ground truth at `camera`: the room's ray cast; a capture's frame when `camera` is one of
// its cameras exactly; else none (a scene file, a capture's other views).
std::optional<GroundTruthImage> ground_truth(const EvalScene& scene, const Camera& camera);

// A camera's eye and viewing direction in world space.
glm::dvec3 eye_of(const Camera& c);
glm::dvec3 forward_of(const Camera& c);

// A near and a far viewpoint on an object (or a set of objects: the resolution's extent),
// both inside the room and chosen by what the ground truth shows of the targets (ray-cast
// at a small size): near = of eight horizontal directions around the target's centre, at
// 1.5 times its size away (at least 1 m; directions the walls cut to less than 3/4 of that
// only when all are), the one that sees most target pixels (the first on a tie); far = the upper room corner farthest from the target among those that see at
// least half as many target pixels as the best corner.
struct ObjectViews {
  Camera near, far;
};
ObjectViews object_views(const QueryResolution& resolution, const SyntheticScene& scene, std::uint32_t width,
                         std::uint32_t height);
// Without ground truth (a scene file), by geometry alone: near = 1.5 times the target's
// size (at least a fifth of the scene's orbit distance) from its centre towards camera 0's
// eye; far = camera 0's eye moved out to 1.5 times its orbit distance; both look at the
// target's centre.
ObjectViews object_views(const QueryResolution& resolution, const EvalScene& scene, std::uint32_t width,
                         std::uint32_t height);

// The appearance Gaussians of the whole scene (carriers excluded), in the store's order:
// what the host's full render (PC) draws.
std::vector<Gaussian> appearance_gaussians(const SceneStore& store);

}  // namespace gauss::eval_app
