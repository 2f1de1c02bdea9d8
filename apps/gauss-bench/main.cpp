// gauss-bench SUBCOMMAND [options]: benchmarks that print a table and write JSON,
// with an error figure beside every time. Timing never decides a test.
#include <cstdio>
#include <cstring>

#include "bench_registry.h"

int main(int argc, char** argv) {
  auto& reg = gauss::bench::registry();
  if (argc < 2 || std::strcmp(argv[1], "--help") == 0 || reg.find(argv[1]) == reg.end()) {
    std::fprintf(stderr, "usage: gauss-bench SUBCOMMAND [options]\n\nsubcommands:\n");
    for (const auto& [name, entry] : reg) std::fprintf(stderr, "  %-10s %s\n", name.c_str(), entry.summary.c_str());
    return argc < 2 || std::strcmp(argv[1], "--help") != 0 ? 2 : 0;
  }
  return reg.at(argv[1]).run(argc - 1, argv + 1);
}
