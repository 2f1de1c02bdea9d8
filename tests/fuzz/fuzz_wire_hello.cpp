// Fuzz target: the Hello body decoder (see fuzz_wire_common.h for the invariants).
#include "fuzz_wire_common.h"

GAUSS_FUZZ_TARGET(wire_hello) {
  return gauss::fuzz::fuzz_body<gauss::msg::Hello>(data, size, gauss::wire::decode_hello);
}
