#pragma once
// A trainer-like next snapshot of an epoch, for identity-tracking tests and benchmarks.
//
// 3DGS trainers write snapshots without persistent ids and reorder Gaussians after
// densification. make_trainer_snapshot() imitates that from a previous epoch: a fraction
// is removed (pruned), a fraction perturbed (a small optimiser step: position by a fraction
// of the Gaussian's largest sigma, log-scales, SH0 and opacity), clones are added far from
// their source with their own colour (densification), everything may drift slightly, then
// the snapshot is randomly permuted and its ids are stripped. `fate` and `truth` record
// what really happened to each snapshot Gaussian, so a tracker's result can be scored.
// Deterministic from the seed.
#include <cstdint>
#include <span>
#include <vector>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/ids.h"

namespace gauss {

struct TrainerSnapshotConfig {
  float removed_fraction{0.02f};    // previous Gaussians dropped
  float perturbed_fraction{0.05f};  // survivors given an optimiser step
  float new_fraction{0.02f};        // clones added, as a fraction of the previous count
  float step_sigmas{0.3f};          // perturbation: position step in largest sigmas
  // Every survivor also moves by this many sigmas (and SH0 by up to 0.01): nothing stays
  // bit-identical, as between two trainer iterations. 0 = untouched survivors.
  float drift_sigmas{0.0f};
};

enum class SnapshotFate : std::uint8_t { Unchanged, Perturbed, New };

struct TrainerSnapshot {
  std::vector<Gaussian> gaussians;  // ids 0, permuted
  std::vector<SnapshotFate> fate;   // per snapshot Gaussian
  std::vector<GaussianId> truth;    // its previous id (Unchanged / Perturbed); 0 for New
  std::size_t removed{0};           // previous Gaussians left out
};

TrainerSnapshot make_trainer_snapshot(std::span<const Gaussian> previous, const TrainerSnapshotConfig& config,
                                      std::uint64_t seed);

}  // namespace gauss
