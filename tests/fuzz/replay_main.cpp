// fuzz_replay TARGET CORPUS_DIR: replays a saved fuzz corpus through one fuzz target (the
// GAUSS_FUZZ_TARGET of that name, linked into this program with all the others): every file
// in the folder, in sorted order. A crash or sanitizer report fails the test; an unknown
// target, or an empty or missing corpus folder, is an error (the corpus is part of the test,
// not optional).
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include "fuzz_target.h"

namespace gauss::fuzz {
namespace {
struct Target {
  const char* name;
  TargetEntry entry;
};
// A function's static: the targets register during static initialisation, in any order.
std::vector<Target>& targets() {
  static std::vector<Target> all;
  return all;
}
}  // namespace

bool register_target(const char* name, TargetEntry entry) {
  targets().push_back(Target{name, entry});
  return true;
}
}  // namespace gauss::fuzz

int main(int argc, char** argv) {
  auto& targets = gauss::fuzz::targets();
  std::sort(targets.begin(), targets.end(), [](const auto& a, const auto& b) { return std::strcmp(a.name, b.name) < 0; });
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s TARGET CORPUS_DIR\ntargets:", argv[0]);
    for (const auto& t : targets) std::fprintf(stderr, " %s", t.name);
    std::fprintf(stderr, "\n");
    return 2;
  }
  const auto it = std::find_if(targets.begin(), targets.end(), [&](const auto& t) { return std::strcmp(t.name, argv[1]) == 0; });
  if (it == targets.end()) {
    std::fprintf(stderr, "no fuzz target named %s (run without arguments for the list)\n", argv[1]);
    return 2;
  }
  std::vector<std::filesystem::path> files;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(argv[2], ec))
    if (e.is_regular_file()) files.push_back(e.path());
  if (ec || files.empty()) {
    std::fprintf(stderr, "no corpus files in %s\n", argv[2]);
    return 1;
  }
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    std::ifstream in(f, std::ios::binary);
    std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    it->entry(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
  }
  std::printf("replayed %zu corpus files from %s through %s\n", files.size(), argv[2], it->name);
  return 0;
}
