// Fuzz target: the Ack body decoder (see fuzz_wire_common.h for the invariants).
#include "fuzz_wire_common.h"

GAUSS_FUZZ_TARGET(wire_ack) {
  return gauss::fuzz::fuzz_body<gauss::msg::Ack>(data, size, gauss::wire::decode_ack);
}
