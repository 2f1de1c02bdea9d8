// Fuzz target: the Welcome body decoder (see fuzz_wire_common.h for the invariants).
#include "fuzz_wire_common.h"

GAUSS_FUZZ_TARGET(wire_welcome) {
  return gauss::fuzz::fuzz_body<gauss::msg::Welcome>(data, size, gauss::wire::decode_welcome);
}
