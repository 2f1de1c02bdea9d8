#pragma once
// The scenes gauss-eval serves: a synthetic room, produced epoch by epoch up to the
// configured count and then held still, with its exact ground truth (colour, depth and
// object ids for any camera), the codec the host streams it with, and the cameras the
// evaluation looks from.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/camera.h"
#include "gauss/engine/codec.h"
#include "gauss/engine/query.h"
#include "gauss/engine/result.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/synthetic_scene.h"
#include "options.h"

namespace gauss::eval_app {

struct EvalScene {
  std::string name;  // "room<variant>"
  int variant{0};
  std::unique_ptr<SyntheticScene> synthetic;
  std::unique_ptr<SceneStore> store;  // held still during the evaluation
  CodecParams codec;
  std::size_t appearance{0};          // Gaussians that can be resident (carriers excluded)
  std::vector<Camera> cameras;        // the fidelity cameras (from the room's trajectory)
};

// Produces room `variant` as the options say. Errors: the scene config (named field).
Expected<EvalScene> make_scene(const Options& options, int variant);

// A pinhole camera at `eye` looking at `target` (y up), with the trajectory's focal ratio
// (fx = 0.75 width: about 67 degrees across).
Camera look_camera(const glm::dvec3& eye, const glm::dvec3& target, std::uint32_t width, std::uint32_t height);

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

// The appearance Gaussians of the whole scene (carriers excluded), in the store's order:
// what the host's full render (PC) draws.
std::vector<Gaussian> appearance_gaussians(const SceneStore& store);

}  // namespace gauss::eval_app
