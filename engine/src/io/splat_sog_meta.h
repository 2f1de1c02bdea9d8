#pragma once
// SOG meta.json: what the images mean and how to dequantise them (splat_sog.cpp has the
// format comment). Private to engine/.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gauss/engine/result.h"

namespace gauss::io {

// The most Gaussians a SOG may declare: 16x the largest scene the host renders (2^20 slots).
// A hostile meta.json with a tiny constant image could otherwise make the reader allocate
// without bound; at this cap the decoded cloud is at most ~4 GiB.
inline constexpr std::size_t kMaxSogGaussians = std::size_t(1) << 24;

// A 256-entry scalar codebook (version 2). meta.json writes an empty k-means cluster's NaN
// centroid as null: such an entry is kept invalid, and a pixel that uses it is an error. A null
// first entry is patched the way the PlayCanvas engine does (entry 1 + (entry 1 - entry 255) /
// 255), since files in circulation have one.
struct SogCodebook {
  std::vector<float> values;
  std::vector<std::uint8_t> valid;  // 1 where values[k] is usable
};

struct SogMeta {
  int version{2};  // 1: legacy (no "version" field, mins/maxs ranges), 2: codebooks
  std::size_t count{0};
  std::array<double, 3> means_min{};  // log domain (see the format comment)
  std::array<double, 3> means_max{};
  // Image names as meta.json gives them (relative to the folder or the archive root).
  std::string means_l, means_u, quats, scales, sh0, shn_centroids, shn_labels;

  // Version 2.
  SogCodebook scales_codebook, sh0_codebook, shn_codebook;
  // Version 1: per-channel linear ranges; sh0 [3] is the opacity logit's range.
  std::array<double, 3> scales_min{}, scales_max{};
  std::array<double, 4> sh0_min{}, sh0_max{};
  double shn_min{0.0}, shn_max{0.0};

  bool has_shn{false};
  int shn_bands{0};          // version 2: from meta.json; version 1: 0 here, taken from the centroid width
  std::size_t shn_count{0};  // version 2 palette size; version 1: 0 (bounded by the centroid image)
};

// Parses and checks meta.json: the fields each version needs, with the right types, finite
// numbers, image names that stay inside the container (no absolute paths, no ".."), and a count
// of at most kMaxSogGaussians. Unknown fields are ignored, as the specification asks. Errors
// name `what` and the JSON path (e.g. "means.mins[2]").
Expected<SogMeta> parse_sog_meta(std::span<const std::uint8_t> text, std::string_view what);

}  // namespace gauss::io
