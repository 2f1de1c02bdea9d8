// Fuzz target: the HeadPose body decoder (see fuzz_wire_common.h for the invariants).
#include "fuzz_wire_common.h"

GAUSS_FUZZ_TARGET(wire_head_pose) {
  return gauss::fuzz::fuzz_body<gauss::msg::HeadPose>(data, size, gauss::wire::decode_head_pose);
}
