// Fuzz target: the AuthConfirm body decoder (see fuzz_wire_common.h for the invariants).
#include "fuzz_wire_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return gauss::fuzz::fuzz_body<gauss::msg::AuthConfirm>(data, size, gauss::wire::decode_auth_confirm);
}
