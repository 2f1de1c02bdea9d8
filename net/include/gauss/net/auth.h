#pragma once
// The handshake's cryptography (issue 28): CPace (cpace.h) between a host that accepts one
// or two secrets (the access token; a pairing code) and a client that holds one of them,
// key confirmation both ways, and the sealed stream's keys. messages.h shows the exchange
// (Hello, Challenge, AuthProof, AuthConfirm); NetHost and NetClient drive it.
//
// CPace's inputs:
//   sid = the host's fresh 32-byte nonce (Challenge.nonce)
//   CI  = the Hello frame exactly as the client sent it: a man in the middle cannot swap
//         the capacity or name without the two sides' generators, and so keys, differing
//   PRS = the secret: the token's bytes, or the pairing code's canonical 8 symbols
//   AD  = empty
// The host is CPace's initiator with one message (and fresh scalar) per secret it accepts;
// the client answers one of them as the responder. From CPace's ISK:
//   PRK = BLAKE2b-512 keyed with ISK, of prefix_free_cat("gauss-pake-v1", Hello frame,
//         Challenge frame, the answered secret as one byte)
//   a key = BLAKE2b-256 keyed with PRK, of its label:
//     "gauss-pake-v1 client confirm"   the client's tag (AuthProof.tag)
//     "gauss-pake-v1 host confirm"     the host's tag (AuthConfirm.tag)
//     "gauss-pake-v1 host to client"   the sealed stream's key, host -> client
//     "gauss-pake-v1 client to host"   the sealed stream's key, client -> host
// The Challenge's bytes in PRK bind its flags (kChallengeEncrypt cannot be stripped on the
// path) and every offer. The host checks the client's tag before it says anything more, so
// a wrong secret learns "authentication failed" and nothing to test a guess with; the
// host's tag then tells the client that the host knows the secret too. Fresh scalars on
// both sides make every key depend on secrets that are gone after the handshake: a
// recorded session stays sealed even from someone who learns the token later.
#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gauss/engine/messages.h"
#include "gauss/engine/result.h"
#include "gauss/net/cpace.h"

namespace gauss::net {

// Initialises libsodium (idempotent, thread-safe). Errors: the library cannot start.
Status auth_init();

using StreamKey = std::array<std::uint8_t, 32>;

// What one handshake yields to both sides. Wiped when destroyed: forward secrecy holds
// only if no copy of a session's keys outlives it.
struct SessionKeys {
  msg::AuthTag client_tag{};
  msg::AuthTag host_tag{};
  StreamKey host_to_client{};
  StreamKey client_to_host{};
  ~SessionKeys();
};
// The key schedule above, from CPace's ISK and the handshake's frames.
SessionKeys derive_session_keys(const cpace::Isk& isk, std::span<const std::uint8_t> hello_frame,
                                std::span<const std::uint8_t> challenge_frame, msg::AuthSecret secret);

// The secrets a host accepts (empty: not accepted; at least one must be set).
struct AuthSecrets {
  std::string access_token;
  std::string pairing_code;  // any form canonical_pairing_code() accepts
};

// The host's side of one connection's handshake. Not thread-safe; one per connection.
class HostHandshake {
 public:
  // Draws the nonce and one scalar per secret, and encodes the Challenge. Requires
  // auth_init() and at least one secret (a pairing code that is not one is left out).
  // `nonce` is for tests that replay a recorded exchange; otherwise drawn here.
  HostHandshake(const AuthSecrets& secrets, std::span<const std::uint8_t> hello_frame, std::uint8_t flags,
                const std::array<std::uint8_t, msg::kAuthNonceBytes>* nonce = nullptr);
  ~HostHandshake();
  HostHandshake(const HostHandshake&) = delete;
  HostHandshake& operator=(const HostHandshake&) = delete;

  const msg::Challenge& challenge() const { return challenge_; }
  // The Challenge as sent: the transcript both sides derive from. Send these bytes.
  const std::vector<std::uint8_t>& challenge_frame() const { return challenge_frame_; }
  // The keys when `proof` answers one of the offers with that secret. Errors, each a
  // refusal naming what was wrong: an offer this host did not make, the client's point
  // does not decode or is the identity, the tag does not match (a wrong secret).
  Expected<SessionKeys> verify(const msg::AuthProof& proof) const;

 private:
  struct Offer {
    msg::AuthSecret secret;
    cpace::Party party;
  };
  std::vector<std::uint8_t> hello_frame_;
  msg::Challenge challenge_;
  std::vector<std::uint8_t> challenge_frame_;
  std::vector<Offer> offers_;
};

// The client's side: its AuthProof for `challenge_frame` (the Challenge exactly as it
// arrived) and the keys, with `secret` (a token, or a pairing code). A pairing code
// answers the host's pairing-code offer when there is one, anything else its token offer.
// Errors: the frame is not a Challenge, the host offers nothing this secret can answer,
// the host's point does not decode or is the identity. Requires auth_init().
struct ClientAnswer {
  msg::AuthProof proof;
  SessionKeys keys;
};
Expected<ClientAnswer> answer_challenge(std::string_view secret, std::span<const std::uint8_t> challenge_frame,
                                        std::span<const std::uint8_t> hello_frame,
                                        const cpace::Scalar* y = nullptr);
// Whether `confirm` is the host's tag for `keys` (constant time).
bool host_confirmed(const SessionKeys& keys, const msg::AuthConfirm& confirm);

// A fresh access token for `--token auto`: 130 bits from the system's CSPRNG as 26
// characters of Crockford's base32 (lower case, no i l o u), in groups of four joined by
// '-', so that a person can read it out and type it: "k3f9-x2ab-...". Requires auth_init().
std::string generate_access_token();

// A pairing code: kPairingCodeSymbols Crockford base32 symbols (40 bits), printed as two
// groups of four ("k3f9-x2ab"), short enough to type on a headset. Safe only because every
// guess costs a live exchange (see weak_token_reason). Requires auth_init().
inline constexpr std::size_t kPairingCodeSymbols = 8;
std::string generate_pairing_code();
// The canonical form of a pairing code as a person may type it (any case, '-' and spaces
// anywhere, Crockford's readings i/l -> 1 and o -> 0), or nullopt when it is not
// kPairingCodeSymbols symbols of the alphabet.
std::optional<std::string> canonical_pairing_code(std::string_view typed);

// Why `token` is weak against a guesser, or nullopt. With CPace nothing on the wire lets
// a guess be tested offline: each guess costs one live exchange, and the host checks at
// most AdmissionConfig::proofs_per_second of them (10 by default) from all addresses
// together, about 3.2e8 a year. kStrongTokenChars random symbols of a 32-symbol alphabet
// are 2^40 = 1.1e12 guesses, about 3,500 years at that rate (the pairing code's strength);
// 6 would be about 3.4 years. Only length can be judged here: a word a person chooses is in
// a guessing list of far fewer entries, whatever its length (10^6 entries: about a day).
inline constexpr std::size_t kStrongTokenChars = 8;
std::optional<std::string> weak_token_reason(std::string_view token);

}  // namespace gauss::net
