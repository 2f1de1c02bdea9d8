// Challenge-response token authentication (see auth.h), on libsodium's BLAKE2b.
#include "gauss/net/auth.h"

#include <sodium.h>

#include <array>
#include <cstring>

namespace gauss::net {

namespace {

constexpr std::string_view kKeyDomain = "gauss-auth-key-v1";
constexpr std::string_view kProofDomain = "gauss-auth-v1";

std::array<std::uint8_t, crypto_generichash_KEYBYTES> derive_key(std::string_view token) {
  std::array<std::uint8_t, crypto_generichash_KEYBYTES> key{};
  crypto_generichash_state st;
  crypto_generichash_init(&st, nullptr, 0, key.size());
  crypto_generichash_update(&st, reinterpret_cast<const unsigned char*>(kKeyDomain.data()), kKeyDomain.size());
  crypto_generichash_update(&st, reinterpret_cast<const unsigned char*>(token.data()), token.size());
  crypto_generichash_final(&st, key.data(), key.size());
  return key;
}

}  // namespace

Status auth_init() {
  if (sodium_init() < 0) return Error{"libsodium could not be initialised"};
  return Ok{};
}

msg::Challenge make_challenge() {
  msg::Challenge c;
  randombytes_buf(c.nonce.data(), c.nonce.size());
  return c;
}

msg::AuthProof auth_proof(std::string_view token, const msg::Challenge& challenge,
                          std::span<const std::uint8_t> hello_frame) {
  static_assert(msg::kAuthProofBytes >= crypto_generichash_BYTES_MIN &&
                msg::kAuthProofBytes <= crypto_generichash_BYTES_MAX);
  auto key = derive_key(token);
  msg::AuthProof p;
  crypto_generichash_state st;
  crypto_generichash_init(&st, key.data(), key.size(), p.mac.size());
  crypto_generichash_update(&st, reinterpret_cast<const unsigned char*>(kProofDomain.data()), kProofDomain.size());
  crypto_generichash_update(&st, challenge.nonce.data(), challenge.nonce.size());
  crypto_generichash_update(&st, hello_frame.data(), hello_frame.size());
  crypto_generichash_final(&st, p.mac.data(), p.mac.size());
  sodium_memzero(key.data(), key.size());
  return p;
}

StreamKey stream_key(std::string_view token, const msg::Challenge& challenge, std::span<const std::uint8_t> hello_frame,
                     std::uint8_t direction) {
  constexpr std::string_view kStreamDomain = "gauss-stream-v1";
  auto key = derive_key(token);
  StreamKey out{};
  crypto_generichash_state st;
  crypto_generichash_init(&st, key.data(), key.size(), out.size());
  crypto_generichash_update(&st, reinterpret_cast<const unsigned char*>(kStreamDomain.data()), kStreamDomain.size());
  crypto_generichash_update(&st, &direction, 1);
  crypto_generichash_update(&st, challenge.nonce.data(), challenge.nonce.size());
  crypto_generichash_update(&st, hello_frame.data(), hello_frame.size());
  crypto_generichash_final(&st, out.data(), out.size());
  sodium_memzero(key.data(), key.size());
  return out;
}

bool verify_auth_proof(std::string_view token, const msg::Challenge& challenge,
                       std::span<const std::uint8_t> hello_frame, const msg::AuthProof& proof) {
  const msg::AuthProof expected = auth_proof(token, challenge, hello_frame);
  return sodium_memcmp(expected.mac.data(), proof.mac.data(), expected.mac.size()) == 0;
}

std::string generate_access_token() {
  static constexpr char kAlphabet[] = "0123456789abcdefghjkmnpqrstvwxyz";  // Crockford base32
  std::array<std::uint8_t, 26> bytes{};
  randombytes_buf(bytes.data(), bytes.size());
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (i > 0 && i % 4 == 0) out += '-';
    out += kAlphabet[bytes[i] & 31u];  // 256 is a multiple of 32: every symbol equally likely
  }
  sodium_memzero(bytes.data(), bytes.size());
  return out;
}

std::optional<std::string> weak_token_reason(std::string_view token) {
  if (token.size() >= kStrongTokenChars) return std::nullopt;
  return "a token of " + std::to_string(token.size()) + " characters can be found by testing guesses against one "
         "recorded handshake, offline; use at least " + std::to_string(kStrongTokenChars) +
         " random characters, or --token auto";
}

}  // namespace gauss::net
