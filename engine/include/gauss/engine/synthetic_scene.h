#pragma once
// Synthetic evolving scenes: the project's embedded default scene (demo and tests).
//
// A procedural indoor room (floor, walls, ceiling, furniture built from boxes, vertical
// cylinders and spheres) with semantic objects (chair x2+, table, plant, keyboard,
// robot_arm, shelf, ...), covered by flat Gaussians oriented by the surface normal, SH
// degree 1. A camera trajectory orbits the room; epoch e holds Gaussians only where the
// cameras of epochs <= e have looked (frustum + facing test). New Gaussians start noisy
// (position jitter, colour off, low opacity, low support) and converge over the following
// epochs; each epoch a few percent are pruned and replaced under new ids; each object has
// a few carrier primitives (carrier = true). Everything is deterministic from the seed
// (own counter-based PRNG, no std distributions).
//
// World frame: metres, y up, floor at y = 0. Cameras use the OpenCV convention
// (gauss::Camera): x right, y down, z forward.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/camera.h"
#include "gauss/engine/image_io.h"
#include "gauss/engine/mesh.h"
#include "gauss/engine/result.h"
#include "gauss/engine/scene_store.h"

namespace gauss {

struct SyntheticSceneConfig {
  int variant{0};                        // room layout / colours / object set, 0..3
  std::uint64_t seed{1};                 // everything random derives from this
  std::size_t target_gaussians{100000};  // appearance Gaussians when the room is fully observed, 1k..2M
  int epochs{12};                        // epochs of the trajectory (>= 1)
  int cameras_per_epoch{4};              // trajectory cameras that observe during one epoch
  int converge_epochs{4};                // epochs a new Gaussian takes to reach its final value
  float prune_fraction{0.02f};           // of live, converged Gaussians pruned + replaced per epoch, [0, 0.5]
  int carriers_per_object{3};            // carrier primitives per semantic object (>= 0)
  std::uint32_t image_width{640};        // trajectory camera intrinsics
  std::uint32_t image_height{480};
  double focal_px{480.0};
  // At the first epoch also set surface_mesh() as surface chunk 0: a stand-in surface for
  // the mesh pass until the TSDF surface exists.
  bool surface_chunk{false};
};

// Ground truth of the analytic scene for one camera.
struct GroundTruthImage {
  ImageRGBA8 colour;          // width x height, alpha 255 where a surface was hit
  std::vector<float> depth;   // metres along the camera z axis (like an RGB-D sensor); 0 = no hit
  // The semantic object whose surface the pixel's ray hit (the same ids as the scene's
  // objects); kNoObject where nothing was hit or the hit belongs to no object (the room
  // shell). Object masks for region metrics come from this.
  std::vector<ObjectId> object;
};

// A semantic object of the synthetic room (the analytic truth behind SceneStore objects).
struct SyntheticObjectInfo {
  ObjectId id{kNoObject};
  std::string label;
  glm::vec3 extent_min{0.0f};  // analytic bounds of the object's primitives
  glm::vec3 extent_max{0.0f};
};

class SyntheticScene {
 public:
  // Validates the config (variant, counts, fractions) and builds the room, the surface
  // samples and the trajectory. Fails with a message naming the bad field.
  static Expected<SyntheticScene> create(const SyntheticSceneConfig& config);

  SyntheticScene(SyntheticScene&&) noexcept;
  SyntheticScene& operator=(SyntheticScene&&) noexcept;
  ~SyntheticScene();

  const SyntheticSceneConfig& config() const;
  int epoch_count() const { return config().epochs; }
  // Synthetic epochs produced so far (the next produce() makes epoch index produced()).
  int produced() const;
  bool finished() const { return produced() >= epoch_count(); }

  // Writes the next epoch into `store` as Epoch{store.epoch() + 1}: inserts newly
  // observed and replacement Gaussians, modifies converging ones, removes pruned ones,
  // declares the objects, sets the SH degree (1). The store must only be fed by this
  // scene (ids are the scene's own). Fails when finished() or the store has an open epoch.
  Status produce(SceneStore& store);

  // Full trajectory, epochs in order: epoch e uses cameras [e * k, (e + 1) * k),
  // k = cameras_per_epoch.
  const std::vector<Camera>& trajectory() const;
  std::span<const Camera> cameras_of_epoch(int e) const;

  // Ray-casts the analytic room: exact depth of the analytic surfaces and their
  // (view-independent, baked-lighting) colour, the same colour the converged Gaussians'
  // SH0 carries. Any camera size works.
  GroundTruthImage render_ground_truth(const Camera& camera) const;

  // Distance from p to the nearest analytic surface (metres).
  float distance_to_surface(const glm::vec3& p) const;
  // The analytic surfaces as a triangle mesh (boxes/cylinders/spheres tessellated):
  // a stand-in surface until the TSDF is available. Vertex colours are the base colours.
  TriangleMesh surface_mesh() const;
  const std::vector<SyntheticObjectInfo>& objects() const;
  // A wide (about 85 degrees) view from high in one corner toward the room's centre:
  // the demo's and the golden test's camera.
  Camera overview_camera(std::uint32_t width, std::uint32_t height) const;
  // Room interior bounds (floor to ceiling, wall to wall).
  glm::vec3 room_min() const;
  glm::vec3 room_max() const;

 private:
  struct Impl;
  explicit SyntheticScene(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace gauss
