#pragma once
// gauss-bench sub-commands register themselves here, one file per benchmark
// (bench_render.cpp, bench_host.cpp, ...), so adding one touches no shared file.
// A sub-command registers a setup function: it adds its options to its CLI11 sub-app
// (bound to an options struct it owns, so --help lists them with their defaults) and
// returns the function that runs the benchmark once the command line has been parsed.
#include <functional>
#include <map>
#include <string>

#include <CLI/CLI.hpp>

namespace gauss::bench {

using BenchRun = std::function<int()>;
using BenchSetup = std::function<BenchRun(CLI::App& cmd)>;

struct BenchEntry {
  std::string summary;
  BenchSetup setup;
};

inline std::map<std::string, BenchEntry>& registry() {
  static std::map<std::string, BenchEntry> r;
  return r;
}

struct BenchRegistrar {
  BenchRegistrar(const std::string& name, std::string summary, BenchSetup setup) {
    registry()[name] = BenchEntry{std::move(summary), std::move(setup)};
  }
};

}  // namespace gauss::bench

#define GAUSS_BENCH(name, summary, fn) \
  static ::gauss::bench::BenchRegistrar gauss_bench_registrar_##fn(name, summary, fn)
