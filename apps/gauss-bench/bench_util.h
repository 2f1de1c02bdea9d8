#pragma once
// What every gauss-bench sub-command needs: clocks (thread and process CPU time, because
// the machines are shared and wall time mostly measures the neighbours; wall time beside
// them), the median, and writing the JSON file with a clear error when it cannot.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <vector>

#include <nlohmann/json.hpp>

namespace gauss::bench {

using Clock = std::chrono::steady_clock;

inline double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

inline double cpu_clock_s(clockid_t id) {
  timespec ts{};
  clock_gettime(id, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}
// CPU time of the calling thread (single-threaded targets: "one core").
inline double thread_cpu_s() { return cpu_clock_s(CLOCK_THREAD_CPUTIME_ID); }
inline double thread_cpu_ms() { return 1e3 * thread_cpu_s(); }
// CPU time of the whole process (all of lavapipe's threads).
inline double process_cpu_ms() { return 1e3 * cpu_clock_s(CLOCK_PROCESS_CPUTIME_ID); }

// Median; the mean of the two middle values for an even count; 0 for none.
inline double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t h = v.size() / 2;
  return v.size() % 2 ? v[h] : 0.5 * (v[h - 1] + v[h]);
}

// Writes doc to path and says so; false (with the reason on stderr) when it cannot.
inline bool write_json(const std::filesystem::path& path, const nlohmann::json& doc, const char* bench) {
  std::ofstream f(path);
  f << doc.dump(2) << "\n";
  f.close();
  if (!f) {
    std::fprintf(stderr, "gauss-bench %s: cannot write %s\n", bench, path.string().c_str());
    return false;
  }
  std::printf("\nwrote %s\n", path.string().c_str());
  return true;
}

}  // namespace gauss::bench
