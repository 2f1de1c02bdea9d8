// Fuzz target: the EditBatchMsg body decoder (see fuzz_wire_common.h for the invariants),
// and the edit-batch codec inside it. The wire keeps the payload opaque, so an accepted
// message's payload also goes through the client's codec decoders, both as the zstd
// frame it should be and as the raw columnar payload (which libFuzzer can mutate
// directly), under session params of every SH degree. Any payload may be rejected (with
// a reason); an accepted one must re-encode to a batch that decodes to the same ids,
// kinds, leaving ids, object ids and epoch.
#include <string>

#include "fuzz_wire_common.h"
#include "gauss/engine/codec.h"

// A named namespace, not an anonymous one: fuzz_replay compiles the targets in unity
// batches, where two files' helpers of the same name would clash.
namespace fuzz_wire_edit_batch {

void check_codec(const std::vector<std::uint8_t>& payload) {
  for (int degree = 0; degree <= gauss::kMaxShDegree; ++degree) {
    gauss::CodecParams params;
    params.box = {glm::vec3(-3.0f, -1.0f, -4.0f), glm::vec3(3.0f, 2.5f, 4.0f)};
    params.sh_degree = degree;
    for (bool raw : {true, false}) {
      auto decoded = raw ? gauss::decode_edit_batch_raw(payload, params) : gauss::decode_edit_batch(payload, params);
      if (!decoded.ok()) {
        if (decoded.message().empty()) gauss::fuzz::fail("codec rejection without a reason");
        continue;
      }
      const gauss::EditBatch& batch = decoded.value();
      auto again = gauss::decode_edit_batch_raw(gauss::encode_edit_batch_raw(batch, params), params);
      if (!again.ok()) gauss::fuzz::fail("codec decoder refused the codec encoder's output");
      const gauss::EditBatch& b2 = again.value();
      if (b2.epoch != batch.epoch || b2.edits.size() != batch.edits.size()) gauss::fuzz::fail("codec round trip changed the batch");
      for (std::size_t i = 0; i < batch.edits.size(); ++i) {
        const gauss::Edit& x = batch.edits[i];
        const gauss::Edit& y = b2.edits[i];
        const bool value = x.kind != gauss::EditKind::Remove;
        if (x.kind != y.kind || x.id != y.id || (x.kind == gauss::EditKind::Replace && x.leaving != y.leaving) ||
            (value && x.value.object != y.value.object))
          gauss::fuzz::fail("codec round trip changed an edit");
      }
    }
  }
}

GAUSS_FUZZ_TARGET(wire_edit_batch) {
  if (auto m = gauss::fuzz::fuzz_decode<gauss::msg::EditBatchMsg>(data, size, gauss::wire::decode_edit_batch_msg))
    check_codec(m->payload);
  return 0;
}

}  // namespace fuzz_wire_edit_batch
