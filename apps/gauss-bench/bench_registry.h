#pragma once
// gauss-bench sub-commands register themselves here, one file per benchmark
// (bench_render.cpp, bench_host.cpp, ...), so adding one touches no shared file.
#include <functional>
#include <map>
#include <string>

namespace gauss::bench {

using BenchMain = std::function<int(int argc, char** argv)>;

struct BenchEntry {
  std::string summary;
  BenchMain run;
};

inline std::map<std::string, BenchEntry>& registry() {
  static std::map<std::string, BenchEntry> r;
  return r;
}

struct BenchRegistrar {
  BenchRegistrar(const std::string& name, std::string summary, BenchMain run) {
    registry()[name] = BenchEntry{std::move(summary), std::move(run)};
  }
};

}  // namespace gauss::bench

#define GAUSS_BENCH(name, summary, fn) \
  static ::gauss::bench::BenchRegistrar gauss_bench_registrar_##fn(name, summary, fn)
