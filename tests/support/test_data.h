#pragma once
// Where the shared real-scene data lives: $GAUSS_DATA_DIR, else ../shared/data
// beside the checkout. Tests that need it skip with a message when it is absent,
// so a clone alone still passes.
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

#include <gtest/gtest.h>

namespace gauss::test {

inline std::optional<std::filesystem::path> data_dir() {
  if (const char* env = std::getenv("GAUSS_DATA_DIR"); env && *env) {
    if (std::filesystem::is_directory(env)) return std::filesystem::path(env);
    return std::nullopt;
  }
  std::filesystem::path p(GAUSS_DATA_DEFAULT);
  if (std::filesystem::is_directory(p)) return p;
  return std::nullopt;
}

// Path of a file under the data folder, or nullopt when absent.
inline std::optional<std::filesystem::path> data_file(const std::string& rel) {
  auto dir = data_dir();
  if (!dir) return std::nullopt;
  auto p = *dir / rel;
  if (!std::filesystem::exists(p)) return std::nullopt;
  return p;
}

// Folder for files a test writes (actual/diff images, logs); created on demand.
inline std::filesystem::path output_dir() {
  std::filesystem::path p(GAUSS_TEST_OUTPUT_DIR);
  std::filesystem::create_directories(p);
  return p;
}

// output_dir() / rel, emptied: what a test writes there is its run's alone.
inline std::filesystem::path fresh_output_dir(const std::string& rel) {
  const std::filesystem::path p = output_dir() / rel;
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p;
}

}  // namespace gauss::test

// Skips the current test when a shared-data file is missing, saying which and why.
#define GAUSS_REQUIRE_DATA(var, rel)                                                     \
  auto var##_opt = ::gauss::test::data_file(rel);                                        \
  if (!var##_opt) {                                                                      \
    GTEST_SKIP() << "shared test data '" << (rel) << "' not found (set GAUSS_DATA_DIR or " \
                 << "place ../shared/data beside the checkout)";                         \
  }                                                                                      \
  const std::filesystem::path var = *var##_opt
