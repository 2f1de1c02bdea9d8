// Differ: sent set -> desired set as Remove / Insert / Update / Replace edits (differ.h).
// The sent state is a vector sorted by id with each record's slot (its sent bytes, kept
// apart so the merge moves 16 bytes an entry); a diff is one merge of it with the (sorted)
// desired ids, which also writes the next sent state. A re-checked record is compared byte
// for byte with what was sent: no hash, so no collision can hide an update.
#include "gauss/engine/differ.h"

#include <algorithm>
#include <cstring>
#include <optional>
#include <string>
#include <type_traits>

namespace gauss {

struct Differ::Impl {
  CodecParams params;
  DiffStats stats;
  struct Sent {
    GaussianId id;
    std::uint32_t slot;  // the record the client holds, as sent, in `records`
  };
  std::vector<Sent> sent;  // sorted by id
  // What the client holds, as sent (write_sent_record), one slot per sent entry: the record
  // of what was sent stays true however the scene or a LoD hierarchy moves on after it.
  std::size_t stride{0};
  std::vector<std::uint8_t> records;
  std::vector<std::uint32_t> free_slots;
  std::uint32_t take_slot() {
    if (!free_slots.empty()) {
      const std::uint32_t slot = free_slots.back();
      free_slots.pop_back();
      return slot;
    }
    const auto slot = static_cast<std::uint32_t>(records.size() / stride);
    records.resize(records.size() + stride);
    return slot;
  }
  // A diff that fails leaves the sent state as it was: the slots it took go back.
  Error fail(Error e) {
    free_slots.insert(free_slots.end(), taken_slots.begin(), taken_slots.end());
    taken_slots.clear();
    batch_records.clear();
    return e;
  }
  std::uint8_t* at(std::uint32_t slot) { return records.data() + std::size_t{slot} * stride; }
  const std::uint8_t* at(std::uint32_t slot) const { return records.data() + std::size_t{slot} * stride; }
  std::vector<Sent> next;  // the next sent state, swapped in after a diff
  std::optional<Epoch> last_epoch;
  // Scratch kept between calls.
  std::vector<GaussianId> leavers;
  // Slots this diff frees (leavers', updated records' old ones) and takes: freed only once
  // the diff succeeds, given back when it fails.
  std::vector<std::uint32_t> retired_slots;
  std::vector<std::uint32_t> taken_slots;
  std::vector<std::uint32_t> enterers;  // positions in the desired selection
  std::vector<std::uint32_t> updated;   // positions in the desired selection
  std::vector<std::uint32_t> updated_slots;  // their new slots
  // The last batch's sent records, one per value edit in batch order (last_sent_records).
  std::vector<std::uint8_t> batch_records;
  std::vector<std::uint32_t> enterer_slots;  // their entries in `next`
  std::vector<std::uint32_t> order;     // desired positions in id order (when not sorted)
  std::vector<GaussianId> modified_scratch;
};

Differ::Differ(CodecParams params) : impl_(std::make_unique<Impl>()) {
  impl_->params = params;
  impl_->stride = sent_record_bytes(std::clamp(params.sh_degree, 0, kMaxShDegree));
}
Differ::Differ(Differ&&) noexcept = default;
Differ& Differ::operator=(Differ&&) noexcept = default;
Differ::~Differ() = default;

const CodecParams& Differ::params() const { return impl_->params; }
const DiffStats& Differ::last_stats() const { return impl_->stats; }
std::size_t Differ::sent_count() const { return impl_->sent.size(); }

bool Differ::is_sent(GaussianId id) const {
  const auto& v = impl_->sent;
  auto it = std::lower_bound(v.begin(), v.end(), id, [](const Impl::Sent& s, GaussianId x) { return s.id < x; });
  return it != v.end() && it->id == id;
}

std::vector<GaussianId> Differ::sent_ids() const {
  std::vector<GaussianId> out;
  out.reserve(impl_->sent.size());
  for (const Impl::Sent& s : impl_->sent) out.push_back(s.id);
  return out;
}

std::optional<Gaussian> Differ::sent_record(GaussianId id) const {
  const auto& v = impl_->sent;
  auto it = std::lower_bound(v.begin(), v.end(), id, [](const Impl::Sent& s, GaussianId x) { return s.id < x; });
  if (it == v.end() || it->id != id) return std::nullopt;
  return read_sent_record(impl_->at(it->slot), id, impl_->params);
}

void Differ::for_each_sent(const std::function<void(const Gaussian&)>& visit) const {
  for (const Impl::Sent& s : impl_->sent) visit(read_sent_record(impl_->at(s.slot), s.id, impl_->params));
}

std::span<const std::uint8_t> Differ::last_sent_records() const { return impl_->batch_records; }

void Differ::reset() {
  impl_->sent.clear();
  impl_->batch_records.clear();
  impl_->records.clear();
  impl_->free_slots.clear();
  impl_->last_epoch.reset();
}

Expected<EditBatch> Differ::diff(const Selection& desired, const SceneStore& scene, std::span<const Gaussian> extra,
                                 std::span<const GaussianId> extra_modified) {
  if (scene.in_epoch()) return Error{"diff: the scene has an open epoch; diff between epochs"};
  return diff_as<EditBatch>(desired, scene.gaussians(), scene.epoch(), modified_since(scene, extra_modified), extra);
}

Expected<EditHeaderBatch> Differ::diff_headers(const Selection& desired, const SceneStore& scene,
                                               std::span<const Gaussian> extra,
                                               std::span<const GaussianId> extra_modified) {
  if (scene.in_epoch()) return Error{"diff: the scene has an open epoch; diff between epochs"};
  return diff_as<EditHeaderBatch>(desired, scene.gaussians(), scene.epoch(), modified_since(scene, extra_modified),
                                  extra);
}

std::optional<std::span<const GaussianId>> Differ::modified_since(const SceneStore& scene,
                                                                   std::span<const GaussianId> extra_modified) {
  Impl& s = *impl_;
  const Epoch now = scene.epoch();
  std::optional<std::span<const GaussianId>> modified;
  if (s.last_epoch && to_underlying(*s.last_epoch) <= to_underlying(now)) {
    // Records can only have changed through `modify` in the epochs since the last diff;
    // inserted ids are new (ids are never reused), so they cannot be sent already.
    s.modified_scratch.clear();
    bool complete = true;
    for (std::uint64_t e = to_underlying(*s.last_epoch) + 1; e <= to_underlying(now); ++e) {
      const EpochChanges* c = scene.changes(Epoch{e});
      if (!c) {
        complete = false;
        break;
      }
      s.modified_scratch.insert(s.modified_scratch.end(), c->modified.begin(), c->modified.end());
    }
    if (complete) {
      s.modified_scratch.insert(s.modified_scratch.end(), extra_modified.begin(), extra_modified.end());
      modified = std::span<const GaussianId>(s.modified_scratch);
    }
  }
  return modified;
}

Expected<EditBatch> Differ::diff(const Selection& desired, std::span<const Gaussian> gaussians, Epoch epoch,
                                 std::optional<std::span<const GaussianId>> modified, std::span<const Gaussian> extra) {
  return diff_as<EditBatch>(desired, gaussians, epoch, modified, extra);
}

template <class Batch>
Expected<Batch> Differ::diff_as(const Selection& desired, std::span<const Gaussian> gaussians, Epoch epoch,
                                std::optional<std::span<const GaussianId>> modified, std::span<const Gaussian> extra) {
  constexpr bool kHeaders = std::is_same_v<Batch, EditHeaderBatch>;
  Impl& s = *impl_;
  s.batch_records.clear();
  const std::size_t m = desired.ids.size();
  if (m != desired.indices.size()) return Error{"diff: selection ids and indices differ in length"};
  if (desired.scene_size != gaussians.size()) {
    return Error{"diff: selection was made from a scene of " + std::to_string(desired.scene_size) +
                 " Gaussians, diffing against " + std::to_string(gaussians.size())};
  }
  // Index i names gaussians[i], or extra[i - gaussians.size()] above the scene (LoD records).
  const std::size_t limit = gaussians.size() + extra.size();
  auto record = [&](std::uint32_t i) -> const Gaussian& {
    return i < gaussians.size() ? gaussians[i] : extra[i - gaussians.size()];
  };
  // Entries whose record is read (enterers, re-checked stayers) are matched against the
  // scene before anything changes; the others are ids only, and reading every record just
  // to check would cost a cache miss per resident Gaussian.
  auto mismatch = [&](std::size_t k) -> std::optional<Error> {
    const std::uint32_t i = desired.indices[k];
    if (i < limit && record(i).id == desired.ids[k]) return std::nullopt;
    return Error{"diff: selection entry " + std::to_string(k) + " (id " + std::to_string(to_underlying(desired.ids[k])) +
                 ") does not match the scene at index " + std::to_string(i)};
  };
  // One pass: indices in range, and ids strictly increasing (sorted and unique), which a
  // Selection guarantees; otherwise sort positions by id and look for repeats.
  bool sorted = true;
  for (std::size_t k = 0; k < m; ++k) {
    if (desired.indices[k] >= limit) return *mismatch(k);
    sorted = sorted && (k == 0 || desired.ids[k - 1] < desired.ids[k]);
  }
  if (!sorted) {
    s.order.resize(m);
    for (std::size_t k = 0; k < m; ++k) s.order[k] = static_cast<std::uint32_t>(k);
    std::sort(s.order.begin(), s.order.end(),
              [&](std::uint32_t a, std::uint32_t b) { return desired.ids[a] < desired.ids[b]; });
    for (std::size_t j = 1; j < m; ++j) {
      if (desired.ids[s.order[j]] == desired.ids[s.order[j - 1]]) {
        return Error{"diff: id " + std::to_string(to_underlying(desired.ids[s.order[j]])) +
                     " appears twice in the selection"};
      }
    }
  }
  auto at = [&](std::size_t j) -> std::uint32_t { return sorted ? static_cast<std::uint32_t>(j) : s.order[j]; };
  // Modified ids sorted and unique, merged alongside (epochs' lists are sorted each).
  const bool rehash_all = !modified.has_value();
  std::vector<GaussianId>& mod = s.modified_scratch;
  if (modified && modified->data() != mod.data()) mod.assign(modified->begin(), modified->end());
  if (modified) {
    if (!std::is_sorted(mod.begin(), mod.end())) std::sort(mod.begin(), mod.end());
    mod.erase(std::unique(mod.begin(), mod.end()), mod.end());
  }

  s.stats = DiffStats{};
  s.leavers.clear();
  s.retired_slots.clear();
  s.taken_slots.clear();
  s.enterers.clear();
  s.enterer_slots.clear();
  s.updated.clear();
  s.updated_slots.clear();
  // One entry of the next sent state per desired id, written in id order.
  s.next.resize(m);
  Impl::Sent* next = s.next.data();
  const Impl::Sent* sent = s.sent.data();
  const std::size_t sent_n = s.sent.size();
  const GaussianId* ids = desired.ids.data();
  std::size_t a = 0;   // sent
  std::size_t b = 0;   // desired (id order)
  std::size_t t = 0;   // next
  std::size_t mi = 0;  // modified
  while (a < sent_n || b < m) {
    if (sorted && !rehash_all && b < m) {
      // Most of a pose update's sent set stays, and stays unmodified: runs of equal ids
      // below the next modified one are copied across without a branch per entry kind.
      while (mi < mod.size() && mod[mi] < ids[b]) ++mi;
      const GaussianId next_modified = mi < mod.size() ? mod[mi] : GaussianId{~std::uint64_t{0}};
      const std::size_t most = std::min(sent_n - a, m - b);
      std::size_t r = 0;
      while (r < most && sent[a + r].id == ids[b + r] && ids[b + r] < next_modified) ++r;
      std::copy(sent + a, sent + a + r, next + t);
      a += r;
      b += r;
      t += r;
      if (a == sent_n && b == m) break;
    }
    const bool has_a = a < sent_n;
    const bool has_b = b < m;
    if (has_a && (!has_b || sent[a].id < ids[at(b)])) {
      s.retired_slots.push_back(sent[a].slot);
      s.leavers.push_back(sent[a++].id);
      continue;
    }
    const std::uint32_t k = at(b++);
    const GaussianId id = ids[k];
    if (!has_a || id < sent[a].id) {
      // Checked against the scene where its record is copied (below), prefetched.
      s.enterers.push_back(k);
      s.enterer_slots.push_back(static_cast<std::uint32_t>(t));
      next[t++] = Impl::Sent{id, 0};  // slot filled below
      continue;
    }
    // Staying: re-quantise only when it may have changed.
    Impl::Sent e = sent[a++];
    bool check = rehash_all;
    if (!check) {
      while (mi < mod.size() && mod[mi] < id) ++mi;
      check = mi < mod.size() && mod[mi] == id;
    }
    if (check) {
      if (auto err = mismatch(k)) return s.fail(*err);
      ++s.stats.rehashed;
      const Gaussian& value = record(desired.indices[k]);
      std::uint8_t fresh[sent_record_bytes(kMaxShDegree)];
      write_sent_record(value, s.params, fresh);
      if (std::memcmp(fresh, s.at(e.slot), s.stride) != 0) {
        // A new slot, so the sent state stays whole should this diff fail further on.
        s.retired_slots.push_back(e.slot);
        e.slot = s.take_slot();
        s.taken_slots.push_back(e.slot);
        std::memcpy(s.at(e.slot), fresh, s.stride);
        s.updated.push_back(k);
        s.updated_slots.push_back(e.slot);
      }
    }
    next[t++] = e;
  }

  Batch batch;
  batch.epoch = epoch;
  const std::size_t replaces = std::min(s.leavers.size(), s.enterers.size());
  // Edits are built in place: a Gaussian is copied once, straight from the scene into its
  // edit (an Edit{...} temporary, or a default-constructed edit assigned to, would write it
  // twice). The scene is large and the copied Gaussians are scattered through it, so the
  // copy is cache misses more than work: the Gaussians a few edits ahead are prefetched, an
  // enterer is checked against the scene there (its record is read anyway), and its sent bytes
  // are taken from its fresh copy rather than from the scene again.
  batch.edits.reserve(s.leavers.size() + s.enterers.size() - replaces + s.updated.size());
  // The value edits' sent records, in batch order, for the encoder (last_sent_records): each
  // is written here once and copied to its slot, so a host quantises a record once.
  s.batch_records.resize((s.enterers.size() + s.updated.size()) * s.stride);
  std::uint8_t* batch_record = s.batch_records.data();
  auto prefetch = [&](std::uint32_t k) {
    const auto* p = reinterpret_cast<const char*>(&record(desired.indices[k]));
    for (std::size_t line = 0; line < sizeof(Gaussian); line += 64) __builtin_prefetch(p + line);
  };
  constexpr std::size_t kAhead = 8;
  for (std::size_t j = 0; j < std::min(kAhead, s.enterers.size()); ++j) prefetch(s.enterers[j]);
  // The Gaussian the sent record is written from: the edit's copy (read once from the scene),
  // or without one the scene's own.
  auto emit = [&](EditKind kind, GaussianId id, GaussianId leaving, const Gaussian& value) -> const Gaussian& {
    if constexpr (kHeaders) {
      batch.edits.push_back(EditHeader{kind, id, leaving});
      return value;
    } else {
      return batch.edits.emplace_back(kind, id, leaving, value).value;
    }
  };
  auto enter = [&](std::size_t j) -> std::optional<Error> {
    if (j + kAhead < s.enterers.size()) prefetch(s.enterers[j + kAhead]);
    const std::uint32_t k = s.enterers[j];
    if (auto err = mismatch(k)) return err;
    const bool replace = j < replaces;
    const Gaussian& value = emit(replace ? EditKind::Replace : EditKind::Insert, desired.ids[k],
                                 replace ? s.leavers[j] : GaussianId{0}, record(desired.indices[k]));
    Impl::Sent& entry = s.next[s.enterer_slots[j]];
    entry.slot = s.take_slot();
    s.taken_slots.push_back(entry.slot);
    write_sent_record(value, s.params, batch_record);
    std::memcpy(s.at(entry.slot), batch_record, s.stride);
    batch_record += s.stride;
    return std::nullopt;
  };
  // Batch order: removes, replaces, updates, inserts. Leavers and enterers are both in
  // ascending id order: a replace pairs them in that order.
  for (std::size_t j = replaces; j < s.leavers.size(); ++j) batch.edits.push_back({EditKind::Remove, s.leavers[j]});
  for (std::size_t j = 0; j < replaces; ++j)
    if (auto err = enter(j)) return s.fail(*err);
  for (std::size_t j = 0; j < s.updated.size(); ++j) {
    const std::uint32_t k = s.updated[j];
    emit(EditKind::Update, desired.ids[k], GaussianId{0}, record(desired.indices[k]));
    std::memcpy(batch_record, s.at(s.updated_slots[j]), s.stride);
    batch_record += s.stride;
  }
  for (std::size_t j = replaces; j < s.enterers.size(); ++j)
    if (auto err = enter(j)) return s.fail(*err);
  s.sent.swap(s.next);
  s.free_slots.insert(s.free_slots.end(), s.retired_slots.begin(), s.retired_slots.end());
  s.stats.replaces = replaces;
  s.stats.removes = s.leavers.size() - replaces;
  s.stats.inserts = s.enterers.size() - replaces;
  s.stats.updates = s.updated.size();
  s.last_epoch = epoch;
  return batch;
}

}  // namespace gauss
