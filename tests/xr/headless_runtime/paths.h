#pragma once
// XrPath atoms of one instance: xrStringToPath / xrPathToString, and the well-formedness
// rule of the spec's "Path Atom Type" section (lower-case letters, digits, '-', '_', '.',
// components separated by single '/', no trailing '/', no "." or ".." component).
#include <cstdint>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "xr_headers.h"

namespace gauss::xr_headless {

bool well_formed_path(std::string_view path);

class PathTable {
 public:
  // The atom for `path` (created on first use). The caller has checked well_formed_path.
  XrPath intern(std::string_view path);
  // The string of `path`, or nullptr for XR_NULL_PATH or a value this instance never gave out.
  const std::string* lookup(XrPath path) const;

 private:
  std::vector<std::string> strings_;  // atom i + 1 is strings_[i]
  std::unordered_map<std::string, XrPath> atoms_;
};

}  // namespace gauss::xr_headless
