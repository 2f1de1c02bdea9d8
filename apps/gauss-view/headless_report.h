#pragma once
// What a headless run leaves for a person to look at: a contact sheet of the frames it
// wrote and a short Markdown report of the figures in summary.json (counts, the query's
// share and convergence, frame times per pass).
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "gauss/engine/result.h"

namespace gauss::view {

// Tiles the PNGs of `frames_dir` (sorted by name, "_right" eyes left out) into one image
// `columns` wide, each scaled down by `shrink` (nearest pixel); at most `max_tiles`,
// evenly picked. Errors: no frames, an unreadable PNG, an unwritable output.
Status write_contact_sheet(const std::filesystem::path& frames_dir, const std::filesystem::path& out,
                           std::uint32_t columns = 6, std::uint32_t shrink = 2, std::uint32_t max_tiles = 24);

// The renderer's passes in the order a frame runs them: the keys of summary.json's
// "gpu_pass_ms_p50", which the report lists in this order (a JSON object sorts its keys).
inline constexpr const char* kGpuPasses[] = {"mesh", "preprocess", "compact", "depth_sort",
                                             "emit", "tile_sort",  "ranges",  "blend"};

// report.md from the run's summary (see headless.cpp for its fields).
Status write_report(const std::filesystem::path& out, const nlohmann::json& summary);

}  // namespace gauss::view
