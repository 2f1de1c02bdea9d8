#pragma once
// What the machine can still give this process: a structure that grows with the scene (the
// host's LoD hierarchy) asks before it is built, so a scene too large for the machine is
// refused with the numbers instead of the process being killed by the kernel's out-of-memory
// handler halfway through.
#include <cstddef>
#include <optional>
#include <string_view>

namespace gauss {

// Linux's MemAvailable (/proc/meminfo: free memory plus what the kernel can reclaim without
// swapping), in bytes; nothing where it cannot be read (another system, no /proc).
std::optional<std::size_t> available_memory_bytes();

// The MemAvailable figure of a /proc/meminfo text, in bytes (what available_memory_bytes()
// parses; apart so that a test can give it any text).
std::optional<std::size_t> mem_available_of(std::string_view meminfo);

}  // namespace gauss
