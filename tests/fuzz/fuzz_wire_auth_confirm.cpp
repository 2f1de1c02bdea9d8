// Fuzz target: the AuthConfirm body decoder (see fuzz_wire_common.h for the invariants).
#include "fuzz_wire_common.h"

GAUSS_FUZZ_TARGET(wire_auth_confirm) {
  return gauss::fuzz::fuzz_body<gauss::msg::AuthConfirm>(data, size, gauss::wire::decode_auth_confirm);
}
