#pragma once
// Authenticated encryption of a connection's frames after the token handshake, for scenes
// that are private (NetHostConfig::encrypt_stream; a Challenge with kChallengeEncrypt
// tells the client). Both ends derive two keys, one per direction, from what only they
// share: the token, the host's fresh nonce and the client's Hello bytes, so keys differ
// per connection and a recorded session decrypts nowhere else.
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
#include <string_view>
#include <vector>

#include "gauss/engine/messages.h"
#include "gauss/engine/result.h"

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
  // The key for `direction` of the connection whose handshake had `challenge` and
  // `hello_frame`, under `token`. Requires auth_init().
  StreamCipher(std::string_view token, const msg::Challenge& challenge, std::span<const std::uint8_t> hello_frame,
               StreamDirection direction);
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
  std::array<std::uint8_t, 32> key_{};
  StreamDirection direction_;
  std::uint64_t next_{0};       // sealing
  bool any_{false};             // opening: a counter was accepted
  std::uint64_t newest_{0};     // opening: the newest accepted counter
  std::vector<std::uint64_t> seen_;  // opening: bitmap of the window below newest_
};

}  // namespace gauss::net
