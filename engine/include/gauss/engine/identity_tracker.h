#pragma once
// Identity tracking for snapshots without persistent ids.
//
// 3DGS trainers write each snapshot without gaussian_id and reorder Gaussians after
// densification. track_identity() matches a new snapshot against the previous epoch so
// unchanged and slightly changed Gaussians keep their ids and the edit stream stays small:
//  1. exact pass: a Gaussian whose position, scales, rotation, opacity and SH0 are
//     bit-identical to a previous one takes its id (the lowest-indexed unused one; records
//     found by hash through an index);
//  2. similarity pass for the rest: spatial hashing on position (cells of twice the search
//     radius, so the 2x2x2 cells around a point hold every candidate), candidates within
//     max_distance_sigmas of the previous Gaussian's largest sigma and within the scale,
//     colour and opacity limits; pairs are taken greedily by ascending cost (ties by index,
//     so the result is deterministic and one-to-one);
//  3. everything left gets a fresh id from `allocate` (in snapshot order).
// Carriers only match carriers. Previous ids that nothing matched are the removed ones.
#include <cstddef>
#include <functional>
#include <span>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/result.h"

namespace gauss {

struct IdentityTrackerConfig {
  // Position tolerance in units of the previous Gaussian's largest sigma (exp(max log_scale)).
  float max_distance_sigmas{1.5f};
  // Spatial hash cell edge in metres; 0 = automatic: twice the search radius of the 90th
  // percentile Gaussian. Radii above half a cell are clamped to half a cell.
  float cell_size{0.0f};
  // Largest per-axis change of log-scale (0.5 ~ a factor of 1.65).
  float max_log_scale_change{0.5f};
  // Largest change of any SH0 coefficient (0.5 ~ 0.14 in colour).
  float max_sh_dc_change{0.5f};
  // Largest change of the opacity logit.
  float max_opacity_logit_change{2.0f};
};

struct IdentityReport {
  std::size_t previous{0};  // Gaussians of the previous epoch
  std::size_t current{0};   // Gaussians of the snapshot
  std::size_t kept{0};      // snapshot Gaussians that took a previous id
  std::size_t exact{0};     //   of which bit-identical (exact pass)
  std::size_t fresh{0};     // snapshot Gaussians given a new id
  std::size_t removed{0};   // previous ids nobody took
  float cell_size{0.0f};    // the spatial hash cell used
};

// Sets current[i].id for every snapshot Gaussian (input ids are ignored). Fails, changing
// nothing, when a snapshot or previous Gaussian has a non-finite position, log-scale,
// opacity or SH0 (naming which and its index), or when the config is not positive/finite.
Expected<IdentityReport> track_identity(std::span<const Gaussian> previous, std::span<Gaussian> current,
                                        const IdentityTrackerConfig& config,
                                        const std::function<GaussianId()>& allocate);

}  // namespace gauss
