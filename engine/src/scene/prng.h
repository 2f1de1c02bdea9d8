#pragma once
// Counter-based randomness for the synthetic scenes: every random value is a pure function
// of (seed, stream, index...), so results never depend on evaluation order, thread count or
// the standard library's distributions (whose output differs between implementations).
#include <cstdint>

#include <glm/vec3.hpp>

namespace gauss::scene {

// SplitMix64 finaliser: a strong 64-bit mix.
constexpr std::uint64_t mix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

constexpr std::uint64_t hash(std::uint64_t a, std::uint64_t b) { return mix64(a ^ mix64(b)); }
constexpr std::uint64_t hash(std::uint64_t a, std::uint64_t b, std::uint64_t c) { return hash(hash(a, b), c); }
constexpr std::uint64_t hash(std::uint64_t a, std::uint64_t b, std::uint64_t c, std::uint64_t d) {
  return hash(hash(a, b, c), d);
}

// Uniform in [0, 1) from the top 24 bits (exact in float).
constexpr float unit(std::uint64_t h) { return float(h >> 40) * (1.0f / 16777216.0f); }
// Uniform in [-1, 1).
constexpr float signed_unit(std::uint64_t h) { return unit(h) * 2.0f - 1.0f; }
// Three independent values in [-1, 1) from one key.
inline glm::vec3 signed_unit3(std::uint64_t key) {
  return {signed_unit(mix64(key ^ 0x1111)), signed_unit(mix64(key ^ 0x2222)), signed_unit(mix64(key ^ 0x3333))};
}

}  // namespace gauss::scene
