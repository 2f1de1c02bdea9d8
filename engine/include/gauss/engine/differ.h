#pragma once
// Differ: the previously sent set -> the new desired set as one edit batch.
//
// Edits: Remove (sent, no longer desired), Insert (desired, not sent), Update (sent and
// still desired, and its quantised record -- what the client would see -- changed), and
// Replace (one leaves and one enters in a single edit, reusing the leaver's slot).
// Leavers and enterers are paired into Replaces in ascending id order; the surplus of
// either stays Remove / Insert. Every batch carries the scene epoch. After diff() the
// differ's sent state is the desired set with the records just sent, so applying the
// batch to the previous client set reproduces the desired set exactly.
//
// The sent state keeps each sent record as the client decodes it (its quantised bytes, ~20-65
// B), so what a client holds can be told exactly after the scene has changed again.
//
// Cost: O(|sent| + |desired|) per call: one sequential merge of the sent ids (kept sorted)
// with the desired ids (sorted, as Selection guarantees), no hashing, no per-id lookups.
// Update detection quantises a staying Gaussian only when the scene says it may have
// changed: SceneStore's change log since the last diff (all of them when the log does not
// reach back that far); for plain spans the caller passes the modified ids or asks for all.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "gauss/engine/codec.h"
#include "gauss/engine/edit.h"
#include "gauss/engine/gaussian.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/result.h"
#include "gauss/engine/scene_store.h"
#include "gauss/engine/selector.h"

namespace gauss {

struct DiffStats {
  std::size_t inserts{0};
  std::size_t removes{0};
  std::size_t updates{0};
  std::size_t replaces{0};
  std::size_t rehashed{0};  // staying Gaussians whose record was re-quantised to check
  std::size_t edits() const { return inserts + removes + updates + replaces; }
};

class Differ {
 public:
  // `params` are the session's codec parameters: they define "the quantised record".
  explicit Differ(CodecParams params);
  Differ(Differ&&) noexcept;
  Differ& operator=(Differ&&) noexcept;
  ~Differ();

  // Diffs against `scene`, which must be the scene `desired` was selected from (same
  // epoch and size; ids are checked at the selection's indices). Epoch of the batch:
  // scene.epoch(). Records the scene does not hold (a LoD cut's interior nodes) are in
  // `extra`: a selection index i >= scene size names extra[i - scene size];
  // `extra_modified` lists those of them whose records may have changed since the previous
  // diff (the scene's change log covers its own).
  Expected<EditBatch> diff(const Selection& desired, const SceneStore& scene, std::span<const Gaussian> extra = {},
                           std::span<const GaussianId> extra_modified = {});
  // The same diff as edit headers: what a sender needs that encodes from last_sent_records
  // (encode_edit_headers), without a copy of each value edit's Gaussian (a joining client's
  // 200k inserts: 58 MB of edits that a host wrote, then only encoded from the records).
  Expected<EditHeaderBatch> diff_headers(const Selection& desired, const SceneStore& scene,
                                         std::span<const Gaussian> extra = {},
                                         std::span<const GaussianId> extra_modified = {});
  // Plain-data form. `modified`: ids whose records may have changed since the previous
  // diff; nullopt means any may have (every staying Gaussian is re-quantised).
  Expected<EditBatch> diff(const Selection& desired, std::span<const Gaussian> gaussians, Epoch epoch,
                           std::optional<std::span<const GaussianId>> modified, std::span<const Gaussian> extra = {});

  const CodecParams& params() const;
  const DiffStats& last_stats() const;
  std::size_t sent_count() const;
  bool is_sent(GaussianId id) const;
  std::vector<GaussianId> sent_ids() const;  // sorted
  // What the client holds for a sent id, exactly as it was sent (quantised and decoded, as
  // the client decodes it), however the scene has moved on since; nullopt when not sent.
  std::optional<Gaussian> sent_record(GaussianId id) const;
  // Each sent record so, in id order.
  void for_each_sent(const std::function<void(const Gaussian&)>& visit) const;
  // The sent record (write_sent_record with params()) of each Replace, Update and Insert edit
  // of the last diff's batch, in the batch's order, sent_record_bytes(params().sh_degree)
  // bytes each: what encode_edit_batch would quantise again (HostSession hands them to it).
  // Empty after a failed diff and after reset().
  std::span<const std::uint8_t> last_sent_records() const;
  // Forgets the sent state (e.g. the client reconnected with an empty set).
  void reset();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  // Since the last diff, as the scene's change log tells (nullopt: any may have changed).
  std::optional<std::span<const GaussianId>> modified_since(const SceneStore& scene,
                                                            std::span<const GaussianId> extra_modified);
  template <class Batch>
  Expected<Batch> diff_as(const Selection& desired, std::span<const Gaussian> gaussians, Epoch epoch,
                          std::optional<std::span<const GaussianId>> modified, std::span<const Gaussian> extra);
};

}  // namespace gauss
