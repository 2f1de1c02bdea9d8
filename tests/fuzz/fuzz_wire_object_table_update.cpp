// Fuzz target: the ObjectTableUpdate body decoder (see fuzz_wire_common.h for the invariants).
#include "fuzz_wire_common.h"

GAUSS_FUZZ_TARGET(wire_object_table_update) {
  return gauss::fuzz::fuzz_body<gauss::msg::ObjectTableUpdate>(data, size, gauss::wire::decode_object_table_update);
}
