#pragma once
// splitmix64: tiny, seedable and identical on every platform (std distributions are
// not), so checksums and seeded simulations reproduce bit for bit everywhere.
#include <cstdint>

namespace gauss {

inline constexpr std::uint64_t kSplitmixGamma = 0x9e3779b97f4a7c15ull;

// One well-mixed 64-bit value from x (the generator's output for state x).
constexpr std::uint64_t splitmix64(std::uint64_t x) {
  x += kSplitmixGamma;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// The stream: the next value of the generator in `state`, advancing it.
constexpr std::uint64_t splitmix64_next(std::uint64_t& state) {
  const std::uint64_t out = splitmix64(state);
  state += kSplitmixGamma;
  return out;
}

// Uniform in [0, 1) from the top 53 bits.
constexpr double unit_double(std::uint64_t v) { return static_cast<double>(v >> 11) * (1.0 / 9007199254740992.0); }

}  // namespace gauss
