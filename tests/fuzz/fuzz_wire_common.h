#pragma once
// Shared body of the wire fuzz targets (one target per decoder, fuzz_wire_<name>.cpp).
// Any input may be rejected; an accepted one must survive the round trip:
//   decode -> encode succeeds (the encoder never refuses what the decoder accepted)
//   -> decode again gives an equal message
//   -> and, for canonical encodings, the very same body bytes.
// A violation aborts, which the replay test and libFuzzer both report.
#include <cstdint>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <optional>
#include <span>
#include <type_traits>

#include "fuzz_target.h"
#include "gauss/engine/wire.h"

namespace gauss::fuzz {

[[noreturn]] inline void fail(const char* what) {
  std::fprintf(stderr, "wire fuzz invariant broken: %s\n", what);
  std::abort();
}

template <class T>
void check_round_trip(const T& value, std::span<const std::uint8_t> body) {
  auto frame = wire::encode(wire::Message{value});
  if (!frame.ok()) fail("encoder refused a message the decoder accepted");
  auto back = wire::decode(frame.value());
  if (!back.ok()) fail("decoder refused the encoder's output");
  const T* again = std::get_if<T>(&back.value());
  if (again == nullptr || !(*again == value)) fail("round trip changed the message");
  // A SurfacePatch recompresses its mesh, so only its content is compared.
  if constexpr (!std::is_same_v<T, msg::SurfacePatch>) {
    const auto& bytes = frame.value();
    if (bytes.size() != wire::kHeaderBytes + body.size() ||
        (!body.empty() && std::memcmp(bytes.data() + wire::kHeaderBytes, body.data(), body.size()) != 0))
      fail("re-encoding is not byte-identical");
  }
}

// True when a decoder accepted its input; a rejection must carry a reason.
template <class E>
bool accepted(const E& decoded) {
  if (!decoded.ok() && decoded.message().empty()) fail("rejection without a reason");
  return decoded.ok();
}

// Decodes one body and checks the invariants; returns the accepted message, if any,
// for targets that check more of it.
template <class T, class Decode>
std::optional<T> fuzz_decode(const std::uint8_t* data, std::size_t size, Decode decode) {
  const std::span<const std::uint8_t> body(data, size);
  auto decoded = decode(body);
  if (!accepted(decoded)) return std::nullopt;
  check_round_trip<T>(decoded.value(), body);
  return std::move(decoded).value();
}

template <class T, class Decode>
int fuzz_body(const std::uint8_t* data, std::size_t size, Decode decode) {
  fuzz_decode<T>(data, size, decode);
  return 0;
}

}  // namespace gauss::fuzz
