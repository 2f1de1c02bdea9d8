// Fuzz target: the whole-frame decoder (header + dispatch to every body decoder).
// An accepted frame must re-encode to the same bytes (SurfacePatch: same content).
#include "fuzz_wire_common.h"

GAUSS_FUZZ_TARGET(wire_frame) {
  const std::span<const std::uint8_t> frame(data, size);
  auto decoded = gauss::wire::decode(frame);
  if (!gauss::fuzz::accepted(decoded)) return 0;
  std::visit([&](const auto& m) { gauss::fuzz::check_round_trip(m, frame.subspan(gauss::wire::kHeaderBytes)); },
             decoded.value());
  return 0;
}
