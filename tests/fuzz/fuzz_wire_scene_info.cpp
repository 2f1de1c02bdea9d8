// Fuzz target: the SceneInfo body decoder (see fuzz_wire_common.h for the invariants).
#include "fuzz_wire_common.h"

GAUSS_FUZZ_TARGET(wire_scene_info) {
  return gauss::fuzz::fuzz_body<gauss::msg::SceneInfo>(data, size, gauss::wire::decode_scene_info);
}
