#pragma once
// A whole text file as a string (empty when it cannot be read): logs and reports in tests.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace gauss::test {

inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace gauss::test
