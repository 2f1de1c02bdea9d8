#include "paths.h"

namespace gauss::xr_headless {

bool well_formed_path(std::string_view path) {
  if (path.size() < 2 || path.size() >= XR_MAX_PATH_LENGTH || path.front() != '/' || path.back() == '/') return false;
  std::size_t start = 1;
  while (start <= path.size()) {
    std::size_t end = path.find('/', start);
    if (end == std::string_view::npos) end = path.size();
    const std::string_view part = path.substr(start, end - start);
    if (part.empty() || part == "." || part == "..") return false;
    for (char c : part) {
      const bool ok = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '_' || c == '.';
      if (!ok) return false;
    }
    start = end + 1;
  }
  return true;
}

XrPath PathTable::intern(std::string_view path) {
  const std::string key(path);
  if (auto it = atoms_.find(key); it != atoms_.end()) return it->second;
  strings_.push_back(key);
  const XrPath atom = strings_.size();
  atoms_.emplace(key, atom);
  return atom;
}

const std::string* PathTable::lookup(XrPath path) const {
  if (path == XR_NULL_PATH || path > strings_.size()) return nullptr;
  return &strings_[path - 1];
}

}  // namespace gauss::xr_headless
