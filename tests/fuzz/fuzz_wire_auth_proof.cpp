// Fuzz target: the AuthProof body decoder (see fuzz_wire_common.h for the invariants).
#include "fuzz_wire_common.h"

GAUSS_FUZZ_TARGET(wire_auth_proof) {
  return gauss::fuzz::fuzz_body<gauss::msg::AuthProof>(data, size, gauss::wire::decode_auth_proof);
}
