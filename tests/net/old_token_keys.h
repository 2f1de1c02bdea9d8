#pragma once
// What protocol version 2 derived from the token and public bytes alone (auth.cpp before
// CPace, removed): the proof and the sealed stream's keys. The tests that show a recorded
// CPace handshake gives an attacker with the token nothing try these first: under
// version 2 they opened every recorded session.
#include <sodium.h>

#include <array>
#include <cstdint>
#include <span>
#include <string_view>

namespace gauss::test {

inline std::array<std::uint8_t, 32> old_token_key(std::string_view token) {
  constexpr std::string_view kDomain = "gauss-auth-key-v1";
  std::array<std::uint8_t, 32> key{};
  crypto_generichash_state st;
  crypto_generichash_init(&st, nullptr, 0, key.size());
  crypto_generichash_update(&st, reinterpret_cast<const unsigned char*>(kDomain.data()), kDomain.size());
  crypto_generichash_update(&st, reinterpret_cast<const unsigned char*>(token.data()), token.size());
  crypto_generichash_final(&st, key.data(), key.size());
  return key;
}

// keyed BLAKE2b-256 under the token's key of `domain` || [direction] || nonce || hello.
inline std::array<std::uint8_t, 32> old_keyed(std::string_view token, std::string_view domain, const std::uint8_t* direction,
                                              std::span<const std::uint8_t> nonce, std::span<const std::uint8_t> hello) {
  const auto key = old_token_key(token);
  std::array<std::uint8_t, 32> out{};
  crypto_generichash_state st;
  crypto_generichash_init(&st, key.data(), key.size(), out.size());
  crypto_generichash_update(&st, reinterpret_cast<const unsigned char*>(domain.data()), domain.size());
  if (direction) crypto_generichash_update(&st, direction, 1);
  crypto_generichash_update(&st, nonce.data(), nonce.size());
  crypto_generichash_update(&st, hello.data(), hello.size());
  crypto_generichash_final(&st, out.data(), out.size());
  return out;
}

// The version-2 proof (AuthProof.mac) and stream key of `direction` (1: host to client,
// 2: client to host) for a connection's nonce and Hello frame.
inline std::array<std::uint8_t, 32> old_auth_proof(std::string_view token, std::span<const std::uint8_t> nonce,
                                                   std::span<const std::uint8_t> hello) {
  return old_keyed(token, "gauss-auth-v1", nullptr, nonce, hello);
}
inline std::array<std::uint8_t, 32> old_stream_key(std::string_view token, std::span<const std::uint8_t> nonce,
                                                   std::span<const std::uint8_t> hello, std::uint8_t direction) {
  return old_keyed(token, "gauss-stream-v1", &direction, nonce, hello);
}

}  // namespace gauss::test
