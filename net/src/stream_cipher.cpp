// Sealed frames after the handshake (see stream_cipher.h), on libsodium's
// XChaCha20-Poly1305 (IETF AEAD).
#include "gauss/net/stream_cipher.h"

#include <sodium.h>

#include <cstring>
#include <limits>

namespace gauss::net {

namespace {

constexpr std::uint64_t kNeverSeen = std::numeric_limits<std::uint64_t>::max();

void put_u16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
void put_u64(std::uint8_t* p, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
std::uint16_t get_u16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
std::uint64_t get_u64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= std::uint64_t{p[i]} << (8 * i);
  return v;
}

std::array<std::uint8_t, crypto_aead_xchacha20poly1305_ietf_NPUBBYTES> nonce_of(StreamDirection d, std::uint64_t counter) {
  std::array<std::uint8_t, crypto_aead_xchacha20poly1305_ietf_NPUBBYTES> n{};
  n[0] = static_cast<std::uint8_t>(d);
  put_u64(n.data() + 1, counter);
  return n;
}

}  // namespace

static_assert(kSealedTagBytes == crypto_aead_xchacha20poly1305_ietf_ABYTES);
static_assert(sizeof(StreamKey) == crypto_aead_xchacha20poly1305_ietf_KEYBYTES);

bool looks_sealed(std::span<const std::uint8_t> packet) {
  return packet.size() >= kSealedHeaderBytes + kSealedTagBytes && get_u16(packet.data()) == kSealedMagic &&
         get_u16(packet.data() + 2) == kSealedVersion;
}

StreamCipher::StreamCipher(const StreamKey& key, StreamDirection direction)
    : key_(key),
      direction_(direction),
      seen_(kReplayWindow, kNeverSeen) {}

StreamCipher::~StreamCipher() { sodium_memzero(key_.data(), key_.size()); }

std::vector<std::uint8_t> StreamCipher::seal(std::span<const std::uint8_t> frame) {
  std::uint64_t counter = 0;
  {
    std::lock_guard lock(mu_);
    counter = next_++;
  }
  std::vector<std::uint8_t> out(kSealedHeaderBytes + frame.size() + kSealedTagBytes);
  put_u16(out.data(), kSealedMagic);
  put_u16(out.data() + 2, kSealedVersion);
  put_u64(out.data() + 4, counter);
  const auto nonce = nonce_of(direction_, counter);
  unsigned long long written = 0;
  // The header is authenticated as associated data: a counter cannot be swapped.
  crypto_aead_xchacha20poly1305_ietf_encrypt(out.data() + kSealedHeaderBytes, &written, frame.data(), frame.size(),
                                             out.data(), kSealedHeaderBytes, nullptr, nonce.data(), key_.data());
  out.resize(kSealedHeaderBytes + written);
  return out;
}

Expected<std::vector<std::uint8_t>> StreamCipher::open(std::span<const std::uint8_t> packet) {
  if (!looks_sealed(packet)) return Error{"not a sealed packet (the stream is encrypted)"};
  const std::uint64_t counter = get_u64(packet.data() + 4);
  {
    std::lock_guard lock(mu_);
    if (any_ && counter <= newest_ && (newest_ - counter >= kReplayWindow || seen_[counter % kReplayWindow] == counter))
      return Error{"sealed packet " + std::to_string(counter) + " replayed or too old"};
  }
  std::vector<std::uint8_t> frame(packet.size() - kSealedHeaderBytes - kSealedTagBytes);
  unsigned long long written = 0;
  const auto nonce = nonce_of(direction_, counter);
  if (crypto_aead_xchacha20poly1305_ietf_decrypt(frame.data(), &written, nullptr, packet.data() + kSealedHeaderBytes,
                                                 packet.size() - kSealedHeaderBytes, packet.data(), kSealedHeaderBytes,
                                                 nonce.data(), key_.data()) != 0)
    return Error{"sealed packet " + std::to_string(counter) + " failed authentication"};
  // Marked only once authentic: a forged packet must not spend a counter.
  std::lock_guard lock(mu_);
  if (!accept_counter(counter)) return Error{"sealed packet " + std::to_string(counter) + " replayed"};
  return frame;
}

// The window: counter c is remembered in seen_[c % W] until a counter W newer takes its
// place; anything older than newest - W counts as replayed.
bool StreamCipher::accept_counter(std::uint64_t counter) {
  if (any_ && counter <= newest_ && (newest_ - counter >= kReplayWindow || seen_[counter % kReplayWindow] == counter))
    return false;  // a duplicate opened concurrently
  seen_[counter % kReplayWindow] = counter;
  if (!any_ || counter > newest_) newest_ = counter;
  any_ = true;
  return true;
}

}  // namespace gauss::net
