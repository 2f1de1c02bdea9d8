// gauss-bench formats: load time and peak memory of splat scene files, per format.
//   gauss-bench formats FILE... [--runs N] [--json F]
// Each file is read with read_splat_file (format detected by content) in a child process
// of its own, so its peak resident memory (getrusage ru_maxrss of that child) is the load's
// alone and not the high-water mark of an earlier, larger file. Time is the median (and
// min..max) of --runs loads, each in a fresh child: wall time, beside the child's CPU time
// (the machines are shared; CPU time is the steadier figure). Give the same scene in
// several formats to compare them; the first row is the reference for the ratios.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "bench_registry.h"
#include "bench_util.h"
#include "gauss/engine/splat_file.h"

namespace {

using namespace gauss::bench;

struct LoadSample {
  bool ok{false};
  double wall_ms{0.0};
  double cpu_ms{0.0};
  double peak_mib{0.0};
  std::size_t gaussians{0};
  int sh_degree{0};
  char format[24]{};
  char error[200]{};
};

// Loads `path` once in a child process; the child writes its LoadSample into a pipe.
LoadSample load_in_child(const std::string& path) {
  LoadSample s;
  int fds[2];
  if (pipe(fds) != 0) {
    std::snprintf(s.error, sizeof s.error, "pipe: %s", std::strerror(errno));
    return s;
  }
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    LoadSample c;
    const double cpu0 = process_cpu_ms();
    const auto t0 = Clock::now();
    auto scene = gauss::read_splat_file(path);
    c.wall_ms = ms_since(t0);
    c.cpu_ms = process_cpu_ms() - cpu0;
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    c.peak_mib = static_cast<double>(ru.ru_maxrss) / 1024.0;  // KiB on Linux
    if (scene) {
      c.ok = true;
      c.gaussians = scene->cloud.gaussians.size();
      c.sh_degree = scene->cloud.sh_degree;
      std::snprintf(c.format, sizeof c.format, "%s", std::string(gauss::to_string(scene->report.format)).c_str());
    } else {
      std::snprintf(c.error, sizeof c.error, "%s", scene.message().c_str());
    }
    const ssize_t n = write(fds[1], &c, sizeof c);
    _exit(n == static_cast<ssize_t>(sizeof c) ? 0 : 1);
  }
  close(fds[1]);
  if (pid < 0) {
    close(fds[0]);
    std::snprintf(s.error, sizeof s.error, "fork: %s", std::strerror(errno));
    return s;
  }
  const ssize_t n = read(fds[0], &s, sizeof s);
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (n != static_cast<ssize_t>(sizeof s)) {
    s = LoadSample{};
    std::snprintf(s.error, sizeof s.error, "the loading process died (status %d)", status);
  }
  return s;
}

int bench_formats(const std::vector<std::string>& files, int runs, const std::string& json_path) {
  rusage self{};
  getrusage(RUSAGE_SELF, &self);
  const double baseline_mib = static_cast<double>(self.ru_maxrss) / 1024.0;
  std::printf("gauss-bench formats: %d load(s) per file, each in a fresh process; peak MiB includes the %.1f MiB\n"
              "this process held when it forked\n\n",
              runs, baseline_mib);
  std::printf("%-44s %-15s %9s %3s %11s %17s %11s %10s %8s\n", "file", "format", "gaussians", "sh", "wall ms",
              "(min..max)", "cpu ms", "peak MiB", "x first");
  nlohmann::json rows = nlohmann::json::array();
  double first_ms = 0.0;
  int failures = 0;
  for (const std::string& f : files) {
    std::vector<double> wall, cpu;
    LoadSample last;
    for (int r = 0; r < runs; ++r) {
      last = load_in_child(f);
      if (!last.ok) break;
      wall.push_back(last.wall_ms);
      cpu.push_back(last.cpu_ms);
    }
    if (!last.ok) {
      ++failures;
      std::printf("%-44s error: %s\n", f.c_str(), last.error);
      rows.push_back({{"file", f}, {"error", last.error}});
      continue;
    }
    const double med = median(wall);
    if (first_ms == 0.0) first_ms = med;
    const auto [lo, hi] = std::minmax_element(wall.begin(), wall.end());
    std::printf("%-44s %-15s %9zu %3d %11.1f %8.1f..%-8.1f %11.1f %10.1f %8.2f\n", f.c_str(), last.format,
                last.gaussians, last.sh_degree, med, *lo, *hi, median(cpu), last.peak_mib, med / first_ms);
    rows.push_back({{"file", f},
                    {"format", last.format},
                    {"gaussians", last.gaussians},
                    {"sh_degree", last.sh_degree},
                    {"wall_ms_median", med},
                    {"wall_ms_min", *lo},
                    {"wall_ms_max", *hi},
                    {"cpu_ms_median", median(cpu)},
                    {"peak_rss_mib", last.peak_mib},
                    {"runs", runs}});
  }
  const nlohmann::json doc{{"baseline_rss_mib", baseline_mib}, {"files", rows}};
  if (!json_path.empty() && !write_json(json_path, doc, "formats")) return 1;
  return failures ? 1 : 0;
}

BenchRun bench_formats_setup(CLI::App& cmd) {
  auto files = std::make_shared<std::vector<std::string>>();
  auto runs = std::make_shared<int>(3);
  auto json_path = std::make_shared<std::string>();
  cmd.add_option("files", *files, "scene files (any splat format; a SOG folder too)")->required()->type_name("FILE");
  cmd.add_option("--runs", *runs, "loads per file")->check(CLI::Range(1, 100));
  cmd.add_option("--json", *json_path, "also write the results as JSON")->type_name("FILE");
  return [=] { return bench_formats(*files, *runs, *json_path); };
}

}  // namespace

GAUSS_BENCH("formats", "splat scene files: load time and peak memory per format, each load in its own process",
            bench_formats_setup);
