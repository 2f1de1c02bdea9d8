#pragma once
// Room in memory for what a reader is about to hold (a file's bytes, a scene's Gaussians),
// asked before it is allocated: a scene too large for this process (a container's limit,
// `ulimit -v`, a small machine) gets an error with the figures, where the allocation would
// have ended the process (the kernel's out-of-memory handler, or std::bad_alloc escaping a
// loader's thread) and taken the scene already open with it.
#include <cstddef>
#include <string_view>
#include <vector>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/result.h"

namespace gauss::io {

// Fails, naming `name` and `what` ("its 3 GiB", "12000000 Gaussians"), when `bytes` is more
// than memory_headroom() gives.
Status check_memory_room(std::size_t bytes, std::string_view name, std::string_view what);

// gs.resize(count) after check_memory_room; an allocation that fails anyway is an error too.
Status resize_cloud(std::vector<Gaussian>& gs, std::size_t count, std::string_view name);

}  // namespace gauss::io
