#pragma once
// Read-only zip archives held in memory (libzip), for containers such as a bundled SOG.
// Private to engine/.
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "gauss/engine/result.h"

struct zip;  // libzip's zip_t

namespace gauss::io {

class ZipArchive {
 public:
  // Opens an archive image. `bytes` must outlive the ZipArchive (nothing is copied). Errors
  // name `name` and what libzip found wrong (not a zip, truncated central directory, ...).
  static Expected<ZipArchive> open(std::span<const std::uint8_t> bytes, std::string_view name);

  std::vector<std::string> entry_names() const;
  bool contains(std::string_view entry) const;

  // One entry, whole, with its CRC checked. Errors name the archive and the entry: missing,
  // declared or actual size above `max_bytes`, a size that disagrees with the directory,
  // damaged compressed data.
  Expected<std::vector<std::uint8_t>> read(std::string_view entry, std::size_t max_bytes) const;

 private:
  struct Closer {
    void operator()(zip* z) const;
  };
  ZipArchive(zip* z, std::string name) : zip_(z), name_(std::move(name)) {}
  std::unique_ptr<zip, Closer> zip_;
  std::string name_;
};

}  // namespace gauss::io
