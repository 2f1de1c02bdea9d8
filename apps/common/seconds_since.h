#pragma once
// Seconds of steady clock since t0: the programs' progress lines and time limits.
#include <chrono>

namespace gauss::apps {

inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace gauss::apps
