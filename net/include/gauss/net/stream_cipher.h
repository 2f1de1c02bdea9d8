#pragma once
// Authenticated encryption of a connection's frames after the token handshake, for scenes
// that are private (NetHostConfig::encrypt_stream; a Challenge with kChallengeEncrypt
// tells the client). Both ends take two keys, one per direction, from the handshake's
// CPace exchange (auth.h, SessionKeys): they depend on both sides' fresh scalars, so keys
// differ per connection and a recorded session opens nowhere, not even to someone who
// learns the token later.
//
// A sealed packet is
//   u16 kSealedMagic | u16 kSealedVersion | u64 counter (LE) | XChaCha20-Poly1305(frame) | 16-byte tag
// with the 24-byte nonce = direction byte || counter || zeros. ENet delivers each channel
// in order but channels (and unreliable poses) overtake one another, and a host seals a
// batch on the caller's thread while its service thread may seal a short reply: so the
// receiver accepts each counter once, within a window of the newest kReplayWindow, rather
// than requiring strict order. A replayed, altered or forged packet is refused.
#include <array>
#include <cstdint>
#include <mutex>
#include <span>
#include <vector>

#include "gauss/engine/result.h"
#include "gauss/net/auth.h"

namespace gauss::net {

inline constexpr std::uint16_t kSealedMagic = 0x5345;  // "ES": no frame type is this large
inline constexpr std::uint16_t kSealedVersion = 1;
inline constexpr std::size_t kSealedHeaderBytes = 12;
inline constexpr std::size_t kSealedTagBytes = 16;
inline constexpr std::size_t kReplayWindow = 4096;

enum class StreamDirection : std::uint8_t { HostToClient = 1, ClientToHost = 2 };

// Whether `packet` starts like a sealed packet (magic and version), without opening it.
bool looks_sealed(std::span<const std::uint8_t> packet);

// One direction's key and counter (sealing) or replay window (opening). Thread-safe.
class StreamCipher {
 public:
  // `key` is the handshake's key for `direction` (SessionKeys::host_to_client or
  // client_to_host). Requires auth_init().
  StreamCipher(const StreamKey& key, StreamDirection direction);
  ~StreamCipher();
  StreamCipher(const StreamCipher&) = delete;
  StreamCipher& operator=(const StreamCipher&) = delete;

  // The sealed packet of `frame` with the next counter.
  std::vector<std::uint8_t> seal(std::span<const std::uint8_t> frame);
  // The frame inside `packet`. Errors: not a sealed packet, a counter seen before or
  // older than the window (a replay), a failed tag (altered, or another key).
  Expected<std::vector<std::uint8_t>> open(std::span<const std::uint8_t> packet);

 private:
  bool accept_counter(std::uint64_t counter);  // under mu_

  std::mutex mu_;
  StreamKey key_{};
  StreamDirection direction_;
  std::uint64_t next_{0};       // sealing
  bool any_{false};             // opening: a counter was accepted
  std::uint64_t newest_{0};     // opening: the newest accepted counter
  std::vector<std::uint64_t> seen_;  // opening: bitmap of the window below newest_
};

}  // namespace gauss::net
