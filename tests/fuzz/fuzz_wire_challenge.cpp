// Fuzz target: the Challenge body decoder (see fuzz_wire_common.h for the invariants).
#include "fuzz_wire_common.h"

GAUSS_FUZZ_TARGET(wire_challenge) {
  return gauss::fuzz::fuzz_body<gauss::msg::Challenge>(data, size, gauss::wire::decode_challenge);
}
