#pragma once
// A new file for a program's output that never overwrites anything: `dir/stem-0001.ext`,
// `-0002`, ... (a viewer's screenshots).
#include <filesystem>
#include <string_view>

#include "gauss/engine/result.h"

namespace gauss {

// The most numbers tried before giving up (names stem-0001 .. stem-9999).
inline constexpr int kMaxNumberedFiles = 9999;

// Creates the first free `dir/stem-NNNN.ext` (NNNN from 0001) empty and exclusively (fopen
// "wx": a name that exists, or that another program creates at the same moment, is
// skipped), and returns its path; the caller then writes it. `ext` includes the dot.
// Errors name the folder: missing or not a folder, not writable, all kMaxNumberedFiles
// names taken.
Expected<std::filesystem::path> create_numbered_file(const std::filesystem::path& dir, std::string_view stem,
                                                     std::string_view ext);

}  // namespace gauss
