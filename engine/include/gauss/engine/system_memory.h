#pragma once
// What the machine can still give this process: a structure that grows with the scene (the
// host's LoD hierarchy, the scene store taking a larger snapshot) asks before it is built,
// so a scene too large is refused with the numbers instead of the process being killed by
// the kernel's out-of-memory handler (or ending on std::bad_alloc) halfway through.
//
// Three limits can bind, and the least of them is the answer: the machine's MemAvailable; a
// cgroup's memory limit (a container started with a memory limit, a systemd slice), where
// /proc/meminfo still shows the whole machine; and the address-space limit (`ulimit -v`),
// under which allocations fail while the machine has plenty.
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace gauss {

struct MemoryHeadroom {
  std::size_t bytes{0};
  // The limit that binds, for a message: "the machine's available memory", "the cgroup's
  // memory limit" or "the address-space limit (ulimit -v)".
  std::string_view bound;
  // "this process can have 12 MiB more (the address-space limit (ulimit -v))": how every
  // refusal for want of memory ends.
  std::string text() const;
};

// What this process can still allocate: the least of MemAvailable, the headroom under every
// cgroup memory limit above it, and under its address-space limit; nothing where none of
// them can be read (another system, no /proc).
std::optional<MemoryHeadroom> memory_headroom();

// Asks the kernel to back [p, p + bytes) with transparent huge pages (its 2 MiB-aligned part;
// nothing for less than 4 MiB, or off Linux), for a buffer that is about to be written whole
// for the first time: a scene's Gaussians, a file's bytes. On this project's VM, where the
// kernel hands out huge pages only on request (THP "madvise"), the first touch of 264 MB on
// 4 KiB pages took 1.05-1.23 s and on huge pages 37 ms, and a 1M-Gaussian PLY spent most of
// its load in page faults. Advice only: ordinary pages where the kernel declines.
void advise_huge_pages(void* p, std::size_t bytes);
// advise_huge_pages for the room `v` has reserved past its size (what a resize or the
// appends after a reserve() will write first).
template <class T, class Alloc>
void advise_huge_pages_for_room(std::vector<T, Alloc>& v) {
  advise_huge_pages(v.data() + v.size(), (v.capacity() - v.size()) * sizeof(T));
}

// The pieces memory_headroom() reads, apart so that a test can give them any text.
//
// The MemAvailable figure of a /proc/meminfo text, in bytes.
std::optional<std::size_t> mem_available_of(std::string_view meminfo);
// The headroom under one cgroup's limit: the limit (cgroup v2 memory.max, v1
// memory.limit_in_bytes) less the usage (memory.current, memory.usage_in_bytes), where the
// usage does not count inactive file cache (memory.stat's total_inactive_file for v1,
// inactive_file for v2), which the kernel reclaims before it kills. Nothing for no limit
// ("max", or v1's near-2^63 figure) or a text that does not parse.
std::optional<std::size_t> cgroup_headroom_of(std::string_view limit, std::string_view usage, std::string_view stat);
// The least headroom under the limits of the cgroup at `path` and its ancestors (a parent's
// limit binds its children too) in a cgroup file system mounted at `mount`: v2's memory.max
// or v1's memory.limit_in_bytes, each with its usage and memory.stat. Nothing when none of
// them has a limit.
std::optional<std::size_t> cgroup_headroom_below(const std::filesystem::path& mount, std::string_view path, bool v2);
// This process's cgroup path from a /proc/self/cgroup text: the v2 entry ("0::/path") when
// `v2`, else the v1 memory controller's ("N:memory:/path", possibly with other controllers).
std::optional<std::string_view> cgroup_path_of(std::string_view proc_self_cgroup, bool v2);
// The virtual size in bytes from a /proc/self/statm text (its first field, in pages).
std::optional<std::size_t> vm_size_of(std::string_view statm, std::size_t page_bytes);

}  // namespace gauss
