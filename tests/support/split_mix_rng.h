#pragma once
// Deterministic randomness for tests (SplitMix64): the same sequence on every compiler and
// standard library, unlike <random>'s distributions.
#include <cstdint>

#include <glm/vec3.hpp>

namespace gauss::test {

struct SplitMixRng {
  std::uint64_t s;
  std::uint64_t next() {
    std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // [0, 1) from the top 24 bits (exact in float).
  float unit() { return float(next() >> 40) / 16777216.0f; }
  float sym() { return unit() * 2.0f - 1.0f; }
  glm::vec3 sym3() { return {sym(), sym(), sym()}; }
  // [lo, hi) from the top 53 bits.
  float uniform(float lo, float hi) { return lo + (hi - lo) * float(double(next() >> 11) * (1.0 / 9007199254740992.0)); }
};

}  // namespace gauss::test
