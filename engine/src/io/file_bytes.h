#pragma once
// Whole-file reads and safe whole-file writes shared by the scene/camera/label readers.
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

#include "gauss/engine/result.h"

namespace gauss::io {

// Reads a regular file into memory. Errors name the path: missing, not a regular file,
// unreadable, or shorter than its reported size. With `bytes_read`, the file is read in
// kReadChunkBytes pieces and the counter advanced after each (a viewer's progress bar).
inline constexpr std::size_t kReadChunkBytes = std::size_t{4} << 20;
Expected<std::vector<std::uint8_t>> read_file_bytes(const std::filesystem::path& path,
                                                    std::atomic<std::uint64_t>* bytes_read = nullptr);

// Writes `bytes` to "<path>.tmp" and renames it over `path`, so a failed or interrupted write
// leaves whatever was at `path` untouched (the temporary file is removed on failure).
Status write_file_atomic(const std::filesystem::path& path, std::span<const std::uint8_t> bytes);

}  // namespace gauss::io
