#include "io/memory_room.h"

#include <new>
#include <string>

#include "gauss/engine/log_text.h"
#include "gauss/engine/system_memory.h"

namespace gauss::io {

Status check_memory_room(std::size_t bytes, std::string_view name, std::string_view what) {
  const auto headroom = memory_headroom();
  if (!headroom || bytes <= headroom->bytes) return Ok{};
  return Error{std::string(name) + ": not enough memory: " + std::string(what) + " need about " + format_bytes(bytes) +
               ", and " + headroom->text()};
}

Status resize_cloud(std::vector<Gaussian>& gs, std::size_t count, std::string_view name) {
  const std::string what = std::to_string(count) + " Gaussians";
  const std::size_t bytes = count > gs.size() ? (count - gs.size()) * sizeof(Gaussian) : 0;
  if (auto s = check_memory_room(bytes, name, what); !s) return s;
  try {
    if (count > gs.capacity()) {
      // Reserved first and advised onto huge pages before resize() writes it: at 1M
      // Gaussians (264 MB) most of a PLY's load was the page faults of this first write.
      gs.reserve(count);
      advise_huge_pages_for_room(gs);
    }
    gs.resize(count);
  } catch (const std::bad_alloc&) {
    return Error{std::string(name) + ": not enough memory: " + what + " need about " + format_bytes(bytes) +
                 ", and allocating them failed"};
  }
  return Ok{};
}

}  // namespace gauss::io
