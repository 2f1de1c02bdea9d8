// Fuzz target: the QueryReply body decoder (see fuzz_wire_common.h for the invariants).
#include "fuzz_wire_common.h"

GAUSS_FUZZ_TARGET(wire_query_reply) {
  return gauss::fuzz::fuzz_body<gauss::msg::QueryReply>(data, size, gauss::wire::decode_query_reply);
}
