// gauss-bench SUBCOMMAND [options]: benchmarks that print a table and write JSON,
// with an error figure beside every time. Timing never decides a test.
// `gauss-bench --help` lists the sub-commands, `gauss-bench SUBCOMMAND --help` their options.
#include <map>
#include <string>

#include "bench_registry.h"
#include "gauss_cli.h"

int main(int argc, char** argv) {
  CLI::App app{"gauss-bench: benchmarks that print a table and optionally write JSON, with an error figure\n"
               "beside every time. Timing never decides a test.",
               "gauss-bench"};
  gauss::apps::configure(app);  // before the sub-commands: they inherit it
  app.require_subcommand(1);
  std::map<std::string, gauss::bench::BenchRun> runs;
  for (const auto& [name, entry] : gauss::bench::registry()) runs[name] = entry.setup(*app.add_subcommand(name, entry.summary));
  if (auto rc = gauss::apps::parse(app, argc, argv)) return *rc;
  return runs.at(app.get_subcommands().front()->get_name())();
}
