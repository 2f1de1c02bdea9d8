// create_numbered_file (numbered_file.h).
#include "gauss/engine/numbered_file.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <system_error>

namespace gauss {

Expected<std::filesystem::path> create_numbered_file(const std::filesystem::path& dir, std::string_view stem,
                                                     std::string_view ext) {
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return Error{dir.string() + ": not a folder (for " + std::string(stem) + " files)"};
  for (int n = 1; n <= kMaxNumberedFiles; ++n) {
    char number[12];  // any int: GCC checks the bound at -O1 and above
    std::snprintf(number, sizeof number, "%04d", n);
    const std::filesystem::path path = dir / (std::string(stem) + "-" + number + std::string(ext));
    // "x": fails with EEXIST when the name exists, so nothing is overwritten, also in a race.
    if (std::FILE* f = std::fopen(path.c_str(), "wbx")) {
      std::fclose(f);
      return path;
    }
    if (errno != EEXIST) return Error{path.string() + ": cannot create: " + std::strerror(errno)};
  }
  return Error{dir.string() + ": " + std::string(stem) + "-0001" + std::string(ext) + " .. -" +
               std::to_string(kMaxNumberedFiles) + " all exist"};
}

}  // namespace gauss
