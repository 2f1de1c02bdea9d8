// Fuzz target: the Query body decoder (see fuzz_wire_common.h for the invariants).
#include "fuzz_wire_common.h"

GAUSS_FUZZ_TARGET(wire_query) {
  return gauss::fuzz::fuzz_body<gauss::msg::Query>(data, size, gauss::wire::decode_query);
}
