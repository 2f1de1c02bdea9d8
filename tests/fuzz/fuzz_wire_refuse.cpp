// Fuzz target: the Refuse body decoder (see fuzz_wire_common.h for the invariants).
#include "fuzz_wire_common.h"

GAUSS_FUZZ_TARGET(wire_refuse) {
  return gauss::fuzz::fuzz_body<gauss::msg::Refuse>(data, size, gauss::wire::decode_refuse);
}
