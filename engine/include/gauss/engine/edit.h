#pragma once
// Stable-identity edits: what the host's differ produces, the codec carries and the
// client's desired state coalesces. Every batch carries the epoch it came from.
#include <cstdint>
#include <vector>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/ids.h"

namespace gauss {

enum class EditKind : std::uint8_t {
  Insert = 0,   // `id` enters with `value`
  Remove = 1,   // `id` leaves
  Update = 2,   // `id` stays, its (quantised) record changed to `value`
  Replace = 3,  // `leaving` leaves and `id` enters with `value`, reusing its slot: one edit
};

struct Edit {
  EditKind kind{EditKind::Insert};
  GaussianId id{0};
  GaussianId leaving{0};  // Replace only
  Gaussian value{};       // Insert, Update, Replace
};

struct EditBatch {
  Epoch epoch{0};
  std::vector<Edit> edits;
};

// An edit without its value, for a sender that holds each value edit's record already
// (Differ::diff_headers and its last_sent_records, encode_edit_headers): 24 bytes an edit
// where an Edit takes 288, so a joining client's first batch of 200k inserts is 5 MB of
// fresh memory instead of 58.
struct EditHeader {
  EditKind kind{EditKind::Insert};
  GaussianId id{0};
  GaussianId leaving{0};  // Replace only
};

struct EditHeaderBatch {
  Epoch epoch{0};
  std::vector<EditHeader> edits;
};

}  // namespace gauss
