#pragma once
// Selector: the desired client set R* (|R*| <= M) for a client's coarse head pose.
//
// Ranking (deterministic: ties broken by lower id):
// - global layer: a pose-independent share of each partition's budget
//   (SelectorConfig::global_fraction) goes to the Gaussians with the highest global
//   utility opacity * support_weight * world radius, so coarse context everywhere
//   survives head turns;
// - view layer: the rest goes by view utility opacity * support_weight * angular radius
//   (world radius / distance) times a facing factor: 1 inside the frustum, ramping down
//   linearly to out_of_view_weight over margin_deg outside it (a ramp, not an edge: a
//   2-degree head turn changes a factor by (1 - w) / 10 in absolute terms, a few percent
//   near the frustum but up to (2 - w) / w near the floor w, so w bounds the churn there:
//   at w = 0.02 such Gaussians swung 5.9x and small head motions churned up to 1.6 % of
//   M on the selector test scene; w = 0.1 caps the swing at 1.9x);
// - hysteresis: a Gaussian resident after the previous select() (or set_resident())
//   has both utilities multiplied by 1 + retention_bonus, so small pose changes do not
//   churn the set.
// Semantic reservation: with a query, eligible appearance Gaussians split into the
// object partition (object id in the resolved set) and the background. Exactly
// M_obj = min(|G_obj|, floor(rho M)) come from the object partition and
// min(|G_bg|, M - M_obj) from the background (no spill between partitions, so the object
// share is exactly M_obj / M). Without a query everything is background.
// Carriers and Gaussians marked ineligible never enter the set.
// Cost: O(N) per call (histogram threshold selection, no sort of N); per-Gaussian static
// terms are cached per scene version and rebuilt when it changes; no allocation per call
// once warm.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <glm/gtc/quaternion.hpp>
#include <glm/vec3.hpp>

#include "gauss/engine/camera.h"
#include "gauss/engine/eligibility.h"
#include "gauss/engine/gaussian.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/query.h"
#include "gauss/engine/result.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/semantic.h"

namespace gauss {

// The client's coarse head pose as the host sees it, in the OpenCV camera convention
// (x right, y down, z forward) so it matches gauss::Camera.
struct ClientPose {
  glm::dvec3 position{0.0};                      // head centre, world metres
  glm::dquat orientation{1.0, 0.0, 0.0, 0.0};    // rotation head -> world (R_world_head)
  double tan_half_fov_x{1.0};                    // tan of half the horizontal FOV (1 = 90 deg)
  double tan_half_fov_y{1.0};

  // Pose and FOV of a pinhole camera (FOV from its intrinsics and image size).
  static ClientPose from_camera(const Camera& camera);
};

struct SelectionRequest {
  std::size_t budget{200000};            // M
  std::size_t client_capacity{400000};   // the client's stable slots; budget must fit
  std::optional<SemanticQuery> query;    // none: ordinary view-dependent selection
  double rho{0.0};                       // reservation fraction in [0, 1]
  // false: the background is counted (background_candidates) but not ranked or selected,
  // global layer included; the selection holds the reservation's leaves only. For a caller
  // that puts something else in the background's place (a LoD cut, lod_selector.h), which
  // then pays for the query's partition alone, and nothing for the view layer without one.
  bool background_leaves{true};
};

// Out-of-range values make select() fail naming the field.
struct SelectorConfig {
  double global_fraction{0.2};      // [0, 1]: share of each partition's budget chosen pose-independently
  double retention_bonus{0.3};      // >= 0: hysteresis, resident utility multiplier is 1 + bonus
  double margin_deg{20.0};          // [0, 90]: facing ramp width outside the frustum (head-turn headroom)
  double out_of_view_weight{0.1};   // (0, 1]: utility factor beyond the ramp (behind / far aside)
  double near_distance{0.05};       // > 0: distances below this count as this (metres)
};

struct Selection {
  Epoch epoch{0};                        // scene epoch the selection was made from
  std::vector<GaussianId> ids;           // the desired set, sorted ascending
  std::vector<std::uint32_t> indices;    // positions in the scene span, parallel to ids
  std::size_t scene_size{0};             // size of the span the indices refer to
  std::size_t budget{0};                 // M
  std::size_t object_budget{0};          // M_obj (0 without a query)
  std::size_t object_candidates{0};      // |G_obj|: eligible appearance Gaussians of the query
  std::size_t background_candidates{0};  // |G_bg|
  std::size_t object_selected{0};        // == object_budget
  std::size_t background_selected{0};
  std::size_t global_selected{0};        // chosen by the global layer (both partitions)
  std::size_t retained{0};               // selected and resident before this call
  // With a LoD cut (lod_selector.h): background_selected counts the cut's nodes, of which
  // lod_interior are interior nodes (ids with kLodInteriorIdBit, indices above scene_size);
  // global_selected and retained stay the leaf selection's.
  std::size_t lod_interior{0};
  std::optional<QueryResolution> query;  // resolution of request.query
};

// Checks M, capacity and rho (also without a query): M = 0, M above the client's
// capacity, or rho outside [0, 1] / NaN are errors.
Status validate_request(const SelectionRequest& request);
// A pose must be finite with a non-zero orientation and finite FOV tangents > 0.
Status validate_client_pose(const ClientPose& pose);
// Every SelectorConfig field in its documented range (the error names the field).
Status validate_selector_config(const SelectorConfig& config);

// The per-Gaussian terms Selectors rank by (positions, extents, weights, in id order), one
// set per scene version, shared by every Selector given this: the sessions of one host
// reading one scene then compute them once per epoch instead of once each (about 40 bytes
// per Gaussian and an O(N) pass per session). Thread-safe: the first Selector to see a
// version builds the set while the others wait.
class SelectorTerms {
 public:
  SelectorTerms();
  ~SelectorTerms();
  SelectorTerms(const SelectorTerms&) = delete;
  SelectorTerms& operator=(const SelectorTerms&) = delete;
  // Sets built so far (one per scene version some Selector asked for).
  std::uint64_t builds() const;

 private:
  friend class Selector;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class Selector {
 public:
  explicit Selector(SelectorConfig config = {});
  Selector(Selector&&) noexcept;
  Selector& operator=(Selector&&) noexcept;
  ~Selector();

  const SelectorConfig& config() const;

  // Selects from a SceneStore between epochs. `eligible`, when not empty, is parallel to
  // scene.gaussians(): 0 excludes a Gaussian (the eligibility filter's verdict).
  Expected<Selection> select(const SceneStore& scene, const ClientPose& pose, const SelectionRequest& request,
                             std::span<const std::uint8_t> eligible = {});
  // Selects from the eligibility filter's verdict for this scene (filter_eligible());
  // fails when it was computed at another epoch or names an index outside the scene.
  Expected<Selection> select(const SceneStore& scene, const ClientPose& pose, const SelectionRequest& request,
                             const EligibleSet& eligible);
  // Same on plain data. `scene_version` must change whenever the span's contents change
  // (static terms are cached per version; SceneStore's overload uses its epoch).
  Expected<Selection> select(std::span<const Gaussian> gaussians, std::span<const SemanticObject> objects,
                             std::uint64_t scene_version, Epoch epoch, const ClientPose& pose,
                             const SelectionRequest& request, std::span<const std::uint8_t> eligible = {});

  // Hysteresis state: by default the previous selection. A host that tracks what the
  // client acknowledged may set it explicitly; clear_resident() forgets it.
  void set_resident(std::span<const GaussianId> ids);
  void clear_resident();
  // Takes its static terms from `terms` (shared with other Selectors of the same scene)
  // instead of computing its own.
  void share_terms(std::shared_ptr<SelectorTerms> terms);

 private:
  friend class SelectorTerms;
  struct StaticTerms;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace gauss
