// Fuzz target: the ClientStats body decoder (see fuzz_wire_common.h for the invariants).
#include "fuzz_wire_common.h"

GAUSS_FUZZ_TARGET(wire_client_stats) {
  return gauss::fuzz::fuzz_body<gauss::msg::ClientStats>(data, size, gauss::wire::decode_client_stats);
}
