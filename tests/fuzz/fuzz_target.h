#pragma once
// GAUSS_FUZZ_TARGET(name) { ... } defines one fuzz target's entry, its input in `data` and
// `size`. A libFuzzer binary (GAUSS_LIBFUZZER defined: one target per binary) gets it as
// LLVMFuzzerTestOneInput; otherwise it is registered under `name` (the corpus folder's
// name) for fuzz_replay, the one program that replays every target's saved corpus in
// CTest. One program instead of one per target: linked under the sanitizers, nineteen
// replay programs took a sixth of the sanitizer build's CPU time.
#include <cstddef>
#include <cstdint>

#if defined(GAUSS_LIBFUZZER)
#define GAUSS_FUZZ_TARGET(name) extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
#else
namespace gauss::fuzz {
using TargetEntry = int (*)(const std::uint8_t* data, std::size_t size);
// Adds a target to fuzz_replay's table (replay_main.cpp); returns true.
bool register_target(const char* name, TargetEntry entry);
}  // namespace gauss::fuzz

#define GAUSS_FUZZ_TARGET(name)                                                                              \
  static int gauss_fuzz_target_##name(const std::uint8_t* data, std::size_t size);                         \
  [[maybe_unused]] static const bool gauss_fuzz_registered_##name =                                        \
      ::gauss::fuzz::register_target(#name, gauss_fuzz_target_##name);                                     \
  static int gauss_fuzz_target_##name(const std::uint8_t* data, std::size_t size)
#endif
