#include "gauss/engine/system_memory.h"

#include <charconv>
#include <fstream>
#include <sstream>
#include <string>

namespace gauss {

std::optional<std::size_t> mem_available_of(std::string_view meminfo) {
  // A line "MemAvailable:   12345678 kB" (the kernel writes kB for KiB).
  constexpr std::string_view kKey = "MemAvailable:";
  std::size_t at = 0;
  while (at < meminfo.size()) {
    std::size_t end = meminfo.find('\n', at);
    if (end == std::string_view::npos) end = meminfo.size();
    std::string_view line = meminfo.substr(at, end - at);
    at = end + 1;
    if (!line.starts_with(kKey)) continue;
    line.remove_prefix(kKey.size());
    while (!line.empty() && (line.front() == ' ' || line.front() == '\t')) line.remove_prefix(1);
    std::size_t kib = 0;
    const auto [rest, ec] = std::from_chars(line.data(), line.data() + line.size(), kib);
    if (ec != std::errc{} || rest == line.data()) return std::nullopt;
    std::string_view unit(rest, std::size_t(line.data() + line.size() - rest));
    while (!unit.empty() && unit.front() == ' ') unit.remove_prefix(1);
    if (unit != "kB" || kib > (~std::size_t{0} >> 10)) return std::nullopt;
    return kib << 10;
  }
  return std::nullopt;
}

std::optional<std::size_t> available_memory_bytes() {
  std::ifstream in("/proc/meminfo");
  if (!in) return std::nullopt;
  std::ostringstream text;
  text << in.rdbuf();
  return mem_available_of(text.str());
}

}  // namespace gauss
