// Fuzz target: the SurfacePatch body decoder (see fuzz_wire_common.h for the invariants).
#include "fuzz_wire_common.h"

GAUSS_FUZZ_TARGET(wire_surface_patch) {
  return gauss::fuzz::fuzz_body<gauss::msg::SurfacePatch>(data, size, gauss::wire::decode_surface_patch);
}
