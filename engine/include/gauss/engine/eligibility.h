#pragma once
// Eligibility filter: which appearance Gaussians may be sent to a client at all
// (reconstruction-dependent criteria: opacity, scale, support, surface consistency).
//
// Rules run in this order and a Gaussian is counted under the first rule that removes it,
// so the per-rule counts add up to considered - eligible:
//   1. non-finite position/scale/opacity (never produced by SceneStore; defensive)
//   2. opacity  = sigmoid(opacity_logit) < min_opacity
//   3. scale    = exp(max log_scale) > max_scale  (huge blobs, floaters)
//   4. scale    = exp(max log_scale) < min_scale  (degenerate specks)
//   5. support  < min_support
//   6. distance to the surface mesh > max_surface_distance (only when > 0 and the store has
//      a non-empty surface; otherwise skipped, and the counts say so)
// Carriers are never eligible (they are not appearance) and are counted apart.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/mesh.h"
#include "gauss/engine/result.h"
#include "gauss/engine/scene_store.h"

namespace gauss {

struct EligibilityConfig {
  float min_opacity{0.02f};          // in [0, 1]; 1/255-ish Gaussians add nothing visible
  float max_scale{2.0f};             // metres, > 0
  float min_scale{0.0f};             // metres, >= 0 (0 = off)
  std::uint32_t min_support{0};      // observations (0 = off)
  float max_surface_distance{0.0f};  // metres, >= 0 (0 = off)
  bool operator==(const EligibilityConfig&) const = default;
};

struct EligibilityCounts {
  std::size_t considered{0};  // appearance Gaussians looked at
  std::size_t eligible{0};
  std::size_t carriers{0};    // skipped: not appearance
  std::size_t removed_non_finite{0};
  std::size_t removed_opacity{0};
  std::size_t removed_scale_large{0};
  std::size_t removed_scale_small{0};
  std::size_t removed_support{0};
  std::size_t removed_surface{0};
  bool surface_rule_applied{false};  // false when off or when the store has no surface
};

struct EligibleSet {
  Epoch epoch{0};                      // the store epoch this was computed at
  std::vector<std::uint32_t> indices;  // into store.gaussians() at that epoch, ascending
  EligibilityCounts counts;
  // The rule it was filtered by (filter_eligible sets it; unknown for a set made otherwise).
  // With it, and the surface rule not applied, a Gaussian's verdict depends on it alone, so a
  // reader may follow the scene's change log instead of comparing every Gaussian.
  std::optional<EligibilityConfig> rule;
};

// Rules 1-5, those that look at a Gaussian alone, as filter_eligible applies them.
class EligibilityOwnRules {
 public:
  explicit EligibilityOwnRules(const EligibilityConfig& config);
  // 0 when an appearance Gaussian passes them all, else the number of the first it fails.
  int first_failed(const Gaussian& g) const;
  bool passes(const Gaussian& g) const { return first_failed(g) == 0; }

 private:
  double min_logit_;
  float log_max_;
  float log_min_;
  std::uint32_t min_support_;
};

// Whether filtering `store` with `config` may apply the surface rule (6): its distance is set
// and the store holds a surface chunk. When not, eligibility is EligibilityOwnRules alone.
bool surface_rule_may_apply(const SceneStore& store, const EligibilityConfig& config);

// Nearest-distance queries against triangle meshes (the surface chunks), through a uniform
// grid of triangle references. Answers "is p within d of the surface" exactly.
class SurfaceDistanceIndex {
 public:
  // `max_query` is the largest distance within() will be asked about (sets the grid cell).
  SurfaceDistanceIndex(std::span<const TriangleMesh* const> meshes, float max_query);
  ~SurfaceDistanceIndex();
  SurfaceDistanceIndex(SurfaceDistanceIndex&&) noexcept;
  SurfaceDistanceIndex& operator=(SurfaceDistanceIndex&&) noexcept;

  bool empty() const;
  // True when some triangle is within distance d (<= max_query) of p.
  bool within(const glm::vec3& p, float d) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Rejects a config with NaN, negative values or min_opacity outside [0, 1], naming the field.
Status validate(const EligibilityConfig& config);

// Filters the store's committed Gaussians. Fails on a bad config or an open epoch.
Expected<EligibleSet> filter_eligible(const SceneStore& store, const EligibilityConfig& config);

// One eligible set per scene epoch for every reader with the same rule (a host's sessions):
// the first to ask in an epoch filters while the others wait, and all hold the same set,
// instead of each session filtering the whole scene (25-38 ms at 1M) and keeping a copy.
// Thread-safe.
class SharedEligibleSet {
 public:
  explicit SharedEligibleSet(EligibilityConfig rule) : rule_(rule) {}
  const EligibilityConfig& rule() const { return rule_; }
  // The scene's set at its epoch; a failure (open epoch, bad rule) is not kept.
  Expected<std::shared_ptr<const EligibleSet>> at(const SceneStore& scene);
  std::uint64_t filters() const;  // sets computed so far

 private:
  const EligibilityConfig rule_;
  mutable std::mutex mutex_;
  std::shared_ptr<const EligibleSet> set_;
  std::uint64_t filters_{0};
};

}  // namespace gauss
