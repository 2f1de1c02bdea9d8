#pragma once
// Per-Gaussian label files: one decimal integer per line, in the scene's vertex order
// (e.g. fruit_drops_labels.txt: 0 = unlabelled, 1..8 = segments). What a label means is the
// caller's business; this only reads them.
// Also accepted (recognised by its leading '{'): a segments.ai point-cloud segmentation export
// (the JSON SuperSplat's segmentation workflow produces): each point's label is the category id
// of its annotation (0 = none), matching the object table read_objects_json takes from the same
// file, so one export gives both (--labels F --objects F). Instances of a category share its id.
//
// Accepted: optional surrounding spaces/tabs, "\n" or "\r\n" line ends, a missing final newline.
// Rejected, naming the input and the 1-based line: an empty line, anything that is not a whole
// int32 ("1.5", "7a", "x"), a line longer than kMaxLabelLineBytes.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string_view>
#include <vector>

#include "gauss/engine/result.h"

namespace gauss {

inline constexpr std::size_t kMaxLabelLineBytes = 64;

Expected<std::vector<std::int32_t>> parse_labels(std::string_view text, std::string_view name);
Expected<std::vector<std::int32_t>> read_labels(const std::filesystem::path& path);

// The caller's length check, with both counts and both names in the message:
// "labels.txt has 4720 labels but scene.ply has 4721 Gaussians".
Status check_label_count(std::span<const std::int32_t> labels, std::size_t gaussian_count,
                         std::string_view labels_name, std::string_view scene_name);

}  // namespace gauss
