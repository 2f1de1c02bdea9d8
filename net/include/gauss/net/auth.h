#pragma once
// Token authentication for the ENet handshake (see msg::Challenge): the access token
// never crosses the wire. The host sends a fresh 32-byte random nonce; the client
// answers with a keyed BLAKE2b-256 (libsodium crypto_generichash) of
//   "gauss-auth-v1" || nonce || the Hello frame exactly as it was sent
// under a key derived from the token (BLAKE2b-256 of "gauss-auth-key-v1" || token).
// Binding the proof to the nonce makes a captured handshake worthless on another
// connection; binding it to the Hello's bytes stops a man in the middle from reusing a
// proof with a Hello of his own (another capacity or name).
#include <array>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "gauss/engine/messages.h"
#include "gauss/engine/result.h"

namespace gauss::net {

// Initialises libsodium (idempotent, thread-safe). Errors: the library cannot start.
Status auth_init();
// A fresh nonce from the system's CSPRNG. Requires auth_init().
msg::Challenge make_challenge();
// The client's answer to `challenge` for the Hello frame it sent.
msg::AuthProof auth_proof(std::string_view token, const msg::Challenge& challenge,
                          std::span<const std::uint8_t> hello_frame);
// The key of one direction of a connection's sealed stream (stream_cipher.h): keyed
// BLAKE2b-256 under the token's key of "gauss-stream-v1" || direction || nonce || the Hello
// frame. Each connection (nonce) and direction gets its own key.
using StreamKey = std::array<std::uint8_t, 32>;
StreamKey stream_key(std::string_view token, const msg::Challenge& challenge, std::span<const std::uint8_t> hello_frame,
                     std::uint8_t direction);
// A fresh access token for `--token auto`: 130 bits from the system's CSPRNG as 26
// characters of Crockford's base32 (lower case, no i l o u), in groups of four joined by
// '-', so that a person can read it out and type it: "k3f9-x2ab-...". Requires auth_init().
std::string generate_access_token();
// Why `token` is weak against a guesser, or nullopt. The proof lets anyone who recorded one
// handshake test guesses offline (auth.h's scheme has no PAKE yet), so only length counts:
// fewer than 20 characters (about 100 bits only if random; what people choose is far less).
inline constexpr std::size_t kStrongTokenChars = 20;
std::optional<std::string> weak_token_reason(std::string_view token);
// Whether `proof` answers `challenge` for `hello_frame` under `token` (constant time).
bool verify_auth_proof(std::string_view token, const msg::Challenge& challenge,
                       std::span<const std::uint8_t> hello_frame, const msg::AuthProof& proof);

}  // namespace gauss::net
