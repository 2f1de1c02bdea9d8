#pragma once
// gauss-demo's command line (CLI11): the options, their defaults and their checks.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace gauss::demo_app {

struct Options {
  int variant{0};                 // synthetic room variant
  std::size_t gaussians{60000};   // target Gaussians of the room
  std::size_t budget{20000};      // M: the client's Gaussian budget
  std::string query{"chair"};     // class of the semantic query
  double rho{0.6};                // share of M reserved for the queried objects
  std::uint32_t width{640}, height{480};
  std::filesystem::path out{"out/demo"};
  std::string device;             // Vulkan device index or name substring
};

// Parses argv. Returns the exit status when the program should stop (0 after --help,
// 2 after a bad command line, CLI11's message printed), else std::nullopt.
std::optional<int> parse_options(int argc, char** argv, Options& out);

}  // namespace gauss::demo_app
