// Differ: sent set -> desired set as Remove / Insert / Update / Replace edits (differ.h).
#include "gauss/engine/differ.h"

#include <algorithm>
#include <string>

#include "select/id_table.h"

namespace gauss {

using select_detail::IdTable;

struct Differ::Impl {
  CodecParams params;
  DiffStats stats;
  struct Sent {
    std::uint64_t hash;  // quantized_hash of the record the client holds
    std::uint32_t pos;   // position in sent_list
  };
  IdTable<Sent> sent;
  std::vector<GaussianId> sent_list;
  // Generation stamps: "in the desired set / modified during this call" without clearing.
  IdTable<std::uint32_t> desired_gen;
  IdTable<std::uint32_t> modified_gen;
  std::uint32_t gen = 0;
  std::optional<Epoch> last_epoch;
  // Scratch kept between calls.
  std::vector<GaussianId> leavers;
  std::vector<std::uint32_t> enterers;  // indices into the desired selection
  std::vector<GaussianId> modified_scratch;

  void erase_sent(GaussianId id) {
    const Sent* e = sent.find(id);
    const std::uint32_t pos = e->pos;
    const GaussianId last = sent_list.back();
    sent_list[pos] = last;
    sent.find(last)->pos = pos;
    sent_list.pop_back();
    sent.erase(id);
  }
};

Differ::Differ(CodecParams params) : impl_(std::make_unique<Impl>()) { impl_->params = params; }
Differ::Differ(Differ&&) noexcept = default;
Differ& Differ::operator=(Differ&&) noexcept = default;
Differ::~Differ() = default;

const CodecParams& Differ::params() const { return impl_->params; }
const DiffStats& Differ::last_stats() const { return impl_->stats; }
std::size_t Differ::sent_count() const { return impl_->sent_list.size(); }
bool Differ::is_sent(GaussianId id) const { return impl_->sent.contains(id); }

std::vector<GaussianId> Differ::sent_ids() const {
  std::vector<GaussianId> out(impl_->sent_list);
  std::sort(out.begin(), out.end());
  return out;
}

void Differ::reset() {
  impl_->sent.clear();
  impl_->sent_list.clear();
  impl_->last_epoch.reset();
}

Expected<EditBatch> Differ::diff(const Selection& desired, const SceneStore& scene) {
  if (scene.in_epoch()) return Error{"diff: the scene has an open epoch; diff between epochs"};
  Impl& s = *impl_;
  const Epoch now = scene.epoch();
  std::optional<std::span<const GaussianId>> modified;
  if (s.last_epoch && to_underlying(*s.last_epoch) <= to_underlying(now)) {
    // Records can only have changed through `modify` in the epochs since the last diff;
    // inserted ids are new (ids are never reused), so they cannot be sent already.
    s.modified_scratch.clear();
    bool complete = true;
    for (std::uint64_t e = to_underlying(*s.last_epoch) + 1; e <= to_underlying(now) && complete; ++e) {
      const EpochChanges* c = scene.changes(Epoch{e});
      if (!c) {
        complete = false;
        break;
      }
      s.modified_scratch.insert(s.modified_scratch.end(), c->modified.begin(), c->modified.end());
    }
    if (complete) modified = std::span<const GaussianId>(s.modified_scratch);
  }
  return diff(desired, scene.gaussians(), now, modified);
}

Expected<EditBatch> Differ::diff(const Selection& desired, std::span<const Gaussian> gaussians, Epoch epoch,
                                 std::optional<std::span<const GaussianId>> modified) {
  Impl& s = *impl_;
  if (desired.ids.size() != desired.indices.size()) {
    return Error{"diff: selection ids and indices differ in length"};
  }
  if (desired.scene_size != gaussians.size()) {
    return Error{"diff: selection was made from a scene of " + std::to_string(desired.scene_size) +
                 " Gaussians, diffing against " + std::to_string(gaussians.size())};
  }
  for (std::size_t k = 0; k < desired.ids.size(); ++k) {
    const std::uint32_t i = desired.indices[k];
    if (i >= gaussians.size() || gaussians[i].id != desired.ids[k]) {
      return Error{"diff: selection entry " + std::to_string(k) + " (id " +
                   std::to_string(to_underlying(desired.ids[k])) + ") does not match the scene at index " +
                   std::to_string(i)};
    }
  }
  if (++s.gen == 0) {  // stamps wrapped: start the tables afresh
    s.desired_gen.clear();
    s.modified_gen.clear();
    s.gen = 1;
  }
  for (GaussianId id : desired.ids) {
    if (const std::uint32_t* g = s.desired_gen.find(id); g && *g == s.gen) {
      return Error{"diff: id " + std::to_string(to_underlying(id)) + " appears twice in the selection"};
    }
    s.desired_gen.set(id, s.gen);
  }
  const bool rehash_all = !modified.has_value();
  if (modified) {
    for (GaussianId id : *modified) s.modified_gen.set(id, s.gen);
  }

  s.stats = DiffStats{};
  s.leavers.clear();
  for (GaussianId id : s.sent_list) {
    const std::uint32_t* g = s.desired_gen.find(id);
    if (!g || *g != s.gen) s.leavers.push_back(id);
  }
  std::sort(s.leavers.begin(), s.leavers.end());

  EditBatch batch;
  batch.epoch = epoch;
  s.enterers.clear();
  std::vector<Edit> updates;
  for (std::size_t k = 0; k < desired.ids.size(); ++k) {
    const GaussianId id = desired.ids[k];
    Impl::Sent* e = s.sent.find(id);
    if (!e) {
      s.enterers.push_back(static_cast<std::uint32_t>(k));
      continue;
    }
    bool check = rehash_all;
    if (!check) {
      const std::uint32_t* g = s.modified_gen.find(id);
      check = g && *g == s.gen;
    }
    if (!check) continue;
    ++s.stats.rehashed;
    const Gaussian& value = gaussians[desired.indices[k]];
    const std::uint64_t h = quantized_hash(value, s.params);
    if (h == e->hash) continue;
    e->hash = h;
    updates.push_back(Edit{EditKind::Update, id, GaussianId{0}, value});
  }
  // Enterers are in ascending id order (the selection's order); sort if a caller's is not.
  std::sort(s.enterers.begin(), s.enterers.end(),
            [&](std::uint32_t a, std::uint32_t b) { return desired.ids[a] < desired.ids[b]; });

  const std::size_t replaces = std::min(s.leavers.size(), s.enterers.size());
  batch.edits.reserve(s.leavers.size() + s.enterers.size() - replaces + updates.size());
  for (std::size_t j = replaces; j < s.leavers.size(); ++j) {
    batch.edits.push_back(Edit{EditKind::Remove, s.leavers[j], GaussianId{0}, Gaussian{}});
  }
  for (std::size_t j = 0; j < replaces; ++j) {
    const std::uint32_t k = s.enterers[j];
    batch.edits.push_back(Edit{EditKind::Replace, desired.ids[k], s.leavers[j], gaussians[desired.indices[k]]});
  }
  for (Edit& u : updates) batch.edits.push_back(std::move(u));
  for (std::size_t j = replaces; j < s.enterers.size(); ++j) {
    const std::uint32_t k = s.enterers[j];
    batch.edits.push_back(Edit{EditKind::Insert, desired.ids[k], GaussianId{0}, gaussians[desired.indices[k]]});
  }

  // Advance the sent state to the desired set.
  for (GaussianId id : s.leavers) s.erase_sent(id);
  for (std::uint32_t k : s.enterers) {
    const GaussianId id = desired.ids[k];
    s.sent.set(id, Impl::Sent{quantized_hash(gaussians[desired.indices[k]], s.params),
                              static_cast<std::uint32_t>(s.sent_list.size())});
    s.sent_list.push_back(id);
  }
  s.stats.replaces = replaces;
  s.stats.removes = s.leavers.size() - replaces;
  s.stats.inserts = s.enterers.size() - replaces;
  s.stats.updates = updates.size();
  s.last_epoch = epoch;
  return batch;
}

}  // namespace gauss
