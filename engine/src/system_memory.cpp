#include "gauss/engine/system_memory.h"

#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <charconv>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "gauss/engine/log_text.h"

namespace gauss {

namespace {

// The lines of a text, the last one with or without its newline.
template <class F>
void for_each_line(std::string_view text, F&& f) {
  std::size_t at = 0;
  while (at < text.size()) {
    std::size_t end = text.find('\n', at);
    if (end == std::string_view::npos) end = text.size();
    f(text.substr(at, end - at));
    at = end + 1;
  }
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\n')) s.remove_suffix(1);
  return s;
}

// A whole text (trimmed) as one unsigned number; nothing for anything else.
std::optional<std::size_t> number_of(std::string_view text) {
  text = trim(text);
  std::size_t v = 0;
  const auto [rest, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc{} || text.empty() || rest != text.data() + text.size()) return std::nullopt;
  return v;
}

// The value of "key value" in a memory.stat text.
std::optional<std::size_t> stat_field(std::string_view stat, std::string_view key) {
  std::optional<std::size_t> out;
  for_each_line(stat, [&](std::string_view line) {
    if (out || !line.starts_with(key) || line.size() <= key.size() || line[key.size()] != ' ') return;
    out = number_of(line.substr(key.size()));
  });
  return out;
}

std::optional<std::string> read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  if (!in) return std::nullopt;
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::optional<std::size_t> cgroups_headroom() {
  const auto self = read_text("/proc/self/cgroup");
  if (!self) return std::nullopt;
  std::optional<std::size_t> least;
  const auto take = [&](std::optional<std::size_t> h) {
    if (h && (!least || *h < *least)) least = h;
  };
  if (const auto v2 = cgroup_path_of(*self, true)) {
    // Pure v2 mounts at /sys/fs/cgroup; a hybrid system has it at .../unified, without
    // the memory controller.
    take(cgroup_headroom_below("/sys/fs/cgroup", *v2, true));
  }
  if (const auto v1 = cgroup_path_of(*self, false)) take(cgroup_headroom_below("/sys/fs/cgroup/memory", *v1, false));
  return least;
}

std::optional<std::size_t> address_space_headroom() {
  rlimit lim{};
  if (getrlimit(RLIMIT_AS, &lim) != 0 || lim.rlim_cur == RLIM_INFINITY) return std::nullopt;
  const long page = sysconf(_SC_PAGESIZE);
  const auto statm = read_text("/proc/self/statm");
  if (!statm || page <= 0) return std::nullopt;
  const auto size = vm_size_of(*statm, static_cast<std::size_t>(page));
  if (!size) return std::nullopt;
  const std::size_t cap = static_cast<std::size_t>(lim.rlim_cur);
  return cap > *size ? cap - *size : 0;
}

}  // namespace

std::optional<std::size_t> mem_available_of(std::string_view meminfo) {
  // A line "MemAvailable:   12345678 kB" (the kernel writes kB for KiB).
  constexpr std::string_view kKey = "MemAvailable:";
  std::optional<std::size_t> out;
  bool seen = false;
  for_each_line(meminfo, [&](std::string_view line) {
    if (seen || !line.starts_with(kKey)) return;
    seen = true;
    line.remove_prefix(kKey.size());
    while (!line.empty() && (line.front() == ' ' || line.front() == '\t')) line.remove_prefix(1);
    std::size_t kib = 0;
    const auto [rest, ec] = std::from_chars(line.data(), line.data() + line.size(), kib);
    if (ec != std::errc{} || rest == line.data()) return;
    std::string_view unit(rest, std::size_t(line.data() + line.size() - rest));
    while (!unit.empty() && unit.front() == ' ') unit.remove_prefix(1);
    if (unit != "kB" || kib > (~std::size_t{0} >> 10)) return;
    out = kib << 10;
  });
  return out;
}

std::optional<std::size_t> cgroup_headroom_of(std::string_view limit, std::string_view usage, std::string_view stat) {
  const auto cap = number_of(limit);  // "max" (v2's no limit) does not parse
  const auto used = number_of(usage);
  // v1 says "no limit" with the largest page-aligned signed 64-bit figure.
  if (!cap || !used || *cap >= (std::size_t{1} << 62)) return std::nullopt;
  std::size_t pinned = *used;
  // The usage counts the cgroup's descendants: v1's matching figure is total_inactive_file
  // (its inactive_file is the cgroup's own), v2 has only inactive_file, already hierarchical.
  auto cache = stat_field(stat, "total_inactive_file");
  if (!cache) cache = stat_field(stat, "inactive_file");
  if (cache) pinned = pinned > *cache ? pinned - *cache : 0;
  return *cap > pinned ? *cap - pinned : 0;
}

std::optional<std::string_view> cgroup_path_of(std::string_view proc_self_cgroup, bool v2) {
  std::optional<std::string_view> out;
  for_each_line(proc_self_cgroup, [&](std::string_view line) {
    if (out) return;
    // hierarchy-id:controller-list:path
    const std::size_t a = line.find(':');
    if (a == std::string_view::npos) return;
    const std::size_t b = line.find(':', a + 1);
    if (b == std::string_view::npos) return;
    const std::string_view id = line.substr(0, a), controllers = line.substr(a + 1, b - a - 1);
    const std::string_view path = line.substr(b + 1);
    if (path.empty() || path.front() != '/') return;
    if (v2) {
      if (id == "0" && controllers.empty()) out = path;
      return;
    }
    std::string_view rest = controllers;
    while (!rest.empty()) {
      const std::size_t comma = rest.find(',');
      if (rest.substr(0, comma) == "memory") {
        out = path;
        return;
      }
      if (comma == std::string_view::npos) break;
      rest.remove_prefix(comma + 1);
    }
  });
  return out;
}

std::optional<std::size_t> vm_size_of(std::string_view statm, std::size_t page_bytes) {
  statm = trim(statm);
  const std::size_t space = statm.find(' ');
  const auto pages = number_of(statm.substr(0, space));
  if (!pages || page_bytes == 0 || *pages > ~std::size_t{0} / page_bytes) return std::nullopt;
  return *pages * page_bytes;
}

// A container sees its own cgroup at the mount's root while /proc/self/cgroup may name the
// host's path: the ancestors that exist are read either way.
std::optional<std::size_t> cgroup_headroom_below(const std::filesystem::path& mount, std::string_view path, bool v2) {
  const char* limit_file = v2 ? "memory.max" : "memory.limit_in_bytes";
  const char* usage_file = v2 ? "memory.current" : "memory.usage_in_bytes";
  std::optional<std::size_t> least;
  // A path outside this cgroup namespace's root ("/../x") is not below the mount: read the
  // root alone.
  if (path.find("..") != std::string_view::npos) path = "/";
  // The cgroup's directory, then each parent up to the mount's root.
  std::vector<std::filesystem::path> dirs{mount};
  for (const auto& part : std::filesystem::path(path).relative_path())
    if (!part.empty()) dirs.push_back(dirs.back() / part);
  for (const auto& dir : dirs) {
    const auto limit = read_text(dir / limit_file);
    const auto usage = read_text(dir / usage_file);
    if (!limit || !usage) continue;  // absent there (the root has none; a host's path in a container)
    const auto stat = read_text(dir / "memory.stat");
    if (const auto h = cgroup_headroom_of(*limit, *usage, stat ? *stat : std::string{}); h && (!least || *h < *least))
      least = h;
  }
  return least;
}

std::string MemoryHeadroom::text() const {
  return "this process can have " + format_bytes(bytes) + " more (" + std::string(bound) + ")";
}

void advise_huge_pages(void* p, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  if (p == nullptr || bytes < (std::size_t{4} << 20)) return;
  const auto begin = reinterpret_cast<std::uintptr_t>(p);
  const std::uintptr_t first = (begin + kHuge - 1) & ~(kHuge - 1);
  const std::uintptr_t last = (begin + bytes) & ~(kHuge - 1);
  if (last > first) (void)madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
#else
  (void)p;
  (void)bytes;
#endif
}

std::optional<MemoryHeadroom> memory_headroom() {
  std::optional<MemoryHeadroom> least;
  const auto take = [&](std::optional<std::size_t> bytes, std::string_view bound) {
    if (bytes && (!least || *bytes < least->bytes)) least = MemoryHeadroom{*bytes, bound};
  };
  if (const auto meminfo = read_text("/proc/meminfo")) take(mem_available_of(*meminfo), "the machine's available memory");
  take(cgroups_headroom(), "the cgroup's memory limit");
  take(address_space_headroom(), "the address-space limit (ulimit -v)");
  return least;
}

}  // namespace gauss
