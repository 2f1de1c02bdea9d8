#include "gauss/engine/publisher.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

namespace gauss {

namespace {

// The lines of an entry that checking and publishing it read: the bookkeeping and the record.
void prefetch_entry(const DesiredState& desired, std::uint32_t index) {
  const char* line = reinterpret_cast<const char*>(&desired.entry(index));
  for (std::size_t off = 0; off < sizeof(DesiredEntry); off += 64) __builtin_prefetch(line + off, 0, 1);
}

constexpr int kInsertQueue = 0, kUpdateQueue = 1, kRemoveQueue = 2;

int queue_of(PendingKind kind) {
  return kind == PendingKind::Remove ? kRemoveQueue : kind == PendingKind::Update ? kUpdateQueue : kInsertQueue;
}

}  // namespace

Publisher::Publisher(PublisherConfig config) : config_(config) {
  // A config with min > max would make the clamp ill-defined: order the bounds.
  if (config_.allowance_min == 0) config_.allowance_min = 1;
  if (config_.allowance_max < config_.allowance_min) config_.allowance_max = config_.allowance_min;
  if (config_.immediate_allowance == 0) config_.immediate_allowance = 1;
  if (config_.rescore_per_frame == 0) config_.rescore_per_frame = 1;
  allowance_ = std::clamp(config_.allowance_initial, config_.allowance_min, config_.allowance_max);
  const float total = config_.w_support + config_.w_view + config_.w_magnitude + config_.w_age;
  priority_scale_ = static_cast<float>(detail::BucketQueue::kBuckets) / std::max(total, 1e-6f);
  // The support term for supports below its saturation, exactly as the formula gives it
  // (a log per arrival is a measurable share of ranking one).
  const float ref = std::max(config_.support_reference, 1.0f);
  const auto lut = static_cast<std::uint32_t>(std::min(ref, 4096.0f)) + 1;
  support_lut_.resize(lut);
  for (std::uint32_t s = 0; s < lut; ++s) support_lut_[s] = std::min(1.0f, std::log1p(static_cast<float>(s)) / std::log1p(ref));
}

bool Publisher::in_view_cone(const glm::vec3& position, const ViewState& view) const {
  const glm::vec3 d = position - view.eye;
  const float dist = glm::length(d);
  return dist <= 1e-6f || glm::dot(d, view.forward) >= config_.view_cos_half_fov * dist;
}

float Publisher::view_relevance(const glm::vec3& position, const ViewState& view) const {
  const glm::vec3 d = position - view.eye;
  const float dist = glm::length(d);
  const float c = dist > 1e-6f ? glm::dot(d, view.forward) / dist : 1.0f;
  const float in_view = c >= config_.view_cos_half_fov ? 1.0f : std::max(0.0f, c) * 0.5f;
  const float r = in_view / (1.0f + dist / std::max(config_.view_distance_reference, 1e-3f));
  return std::isfinite(r) ? r : 0.0f;
}

float Publisher::support_term(std::uint32_t support) const {
  if (support < support_lut_.size()) return support_lut_[support];
  const float ref = std::max(config_.support_reference, 1.0f);
  return std::min(1.0f, std::log1p(static_cast<float>(support)) / std::log1p(ref));
}

// Priority: w_support * support + w_view * relevance + w_magnitude * magnitude + w_age * age,
// each term in [0, 1]. A leaving Gaussian's support says nothing about how urgently it
// should go, and one outside the view cone is not seen: removes out of view differ only
// by magnitude and age (and go in slot order as room for inserts).
float Publisher::score(const Candidate& c) const {
  float relevance = 0.0f;
  if (c.kind != PendingKind::Remove || in_view_cone(c.position, view_)) relevance = view_relevance(c.position, view_);
  const float age = std::min(1.0f, static_cast<float>(now_ - c.since) / std::max(config_.age_reference_s, 1e-3f));
  const float p = c.base + config_.w_view * relevance + config_.w_age * std::max(0.0f, age);
  return std::isfinite(p) ? p : 0.0f;
}

int Publisher::bucket_of(float priority) const {
  const float b = priority * priority_scale_;
  if (!(b > 0.0f)) return 0;
  return std::min(detail::BucketQueue::kBuckets - 1, static_cast<int>(b));
}

// Removes as room for inserts: outside the view cone all alike (class 0: none of them is
// seen), inside it by relevance in 1/16 steps.
int Publisher::remove_class(const glm::vec3& position) const {
  if (!in_view_cone(position, view_)) return 0;
  return 1 + static_cast<int>(std::min(15.0f, view_relevance(position, view_) * 16.0f));
}

Publisher::Candidate Publisher::candidate_of(const PendingArrival& a) {
  Candidate c;
  c.position = a.position;
  c.since = a.since;
  c.id = a.id;
  c.index = a.index;
  c.slot = a.slot;
  c.kind = a.kind;
  const float support = a.kind == PendingKind::Remove ? 0.0f : support_term(a.support);
  c.base = config_.w_support * support + config_.w_magnitude * a.magnitude;
  if (!std::isfinite(c.base)) c.base = 0.0f;
  if (++next_seq_ == 0) next_seq_ = 1;  // 0 marks "none"; a wrap needs 2^32 rankings in between
  c.seq = next_seq_;
  seq_[a.index] = c.seq;  // publish() sized seq_ and seen_ for every entry index
  seen_[a.index] = a.stamp;
  return c;
}

void Publisher::push_candidate(Candidate c) {
  if (c.kind == PendingKind::Remove) {
    c.remove_class = static_cast<std::uint8_t>(remove_class(c.position));
    if (c.slot != kNoSlot) removes_.set(to_underlying(c.slot), c.remove_class, c.index);
  }
  queues_[static_cast<std::size_t>(queue_of(c.kind))].push(c, bucket_of(score(c)));
}

bool Publisher::still_pending(const DesiredState& desired, std::uint32_t index, GaussianId id) {
  const DesiredEntry& e = desired.entry(index);
  return e.id == id && e.pending_kind() != PendingKind::None;
}

void Publisher::forget(const DesiredState& desired, std::uint32_t index, SlotIndex slot) {
  if (index < seq_.size()) {
    seq_[index] = 0;
    seen_[index] = desired.change_count();
  }
  if (slot != kNoSlot) removes_.clear(to_underlying(slot));
}

double Publisher::charged_work(const PublishReport& rep) const {
  return static_cast<double>(rep.slot_writes() - rep.escaped) +
         static_cast<double>(config_.range_cost) * static_cast<double>(rep.new_ranges - escaped_ranges_);
}

bool Publisher::over_budget(const PublishReport& rep) const {
  if (config_.max_new_ranges > 0 && rep.new_ranges >= config_.max_new_ranges) return true;
  return budget_ > 0.0 && charged_work(rep) >= budget_;
}

void Publisher::count_range(const SlotTable& slots, SlotIndex slot, PublishReport& rep) const {
  if (!(config_.range_cost > 0.0f) && config_.max_new_ranges == 0) return;
  const std::uint32_t s = to_underlying(slot);
  const std::uint32_t reach = config_.range_gap + 1;
  for (std::uint32_t d = 1; d <= reach; ++d)
    if ((d <= s && slots.is_dirty(s - d)) || slots.is_dirty(s + d)) return;
  ++rep.new_ranges;
}

Status Publisher::publish_entry(DesiredState& desired, SlotTable& slots, std::uint32_t index, PublishReport& rep) {
  const DesiredEntry& e = desired.entry(index);
  // The slot a remove or update writes (an insert learns its slot from the table).
  auto held = [&] { return e.slot != kNoSlot ? e.slot : slots.slot_of(e.id); };
  switch (e.pending_kind()) {
    case PendingKind::Remove: {
      const SlotIndex slot = held();
      Status s = slots.remove(e.id);
      if (!s) return s;
      ++rep.removed;
      count_range(slots, slot, rep);
      forget(desired, index, slot);
      break;
    }
    case PendingKind::Update: {
      const SlotIndex slot = held();
      Status s = slots.update(e.id, e.value);
      if (!s) return s;
      ++rep.updated;
      count_range(slots, slot, rep);
      forget(desired, index, slot);
      break;
    }
    case PendingKind::Insert: {
      auto s = slots.insert(e.id, e.value);
      if (!s) return s.error();
      ++rep.inserted;
      count_range(slots, *s, rep);
      forget(desired, index, *s);
      desired.mark_published(index, *s);
      return Ok{};
    }
    case PendingKind::None: return Ok{};
  }
  desired.mark_published(index);
  return Ok{};
}

// --- ranking upkeep --------------------------------------------------------------------

void Publisher::take_arrivals(DesiredState& desired) {
  // Empty lists with memory go back to DesiredState in the swap.
  if (!spare_chunks_.empty()) {
    taken_.removes = std::move(spare_chunks_.back());
    spare_chunks_.pop_back();
  }
  if (!spare_chunks_.empty()) {
    taken_.others = std::move(spare_chunks_.back());
    spare_chunks_.pop_back();
  }
  desired.take_pending_arrivals(taken_);
  // A Publisher's first frame ranks whatever was pending before it, unless its lists are
  // the DesiredState's first (another consumer may have taken the arrivals that named it).
  const bool first = !started_;
  started_ = true;
  if (taken_.overflowed || (first && !taken_.complete)) {
    // More arrived than the lists hold: what they named is lost, so every pending entry
    // is ranked again, a slice per frame, from its entry (the lists' chunks still held
    // stay valid). Copying the indices is the one step that follows the backlog.
    rescan_.assign(desired.pending().begin(), desired.pending().end());
    rescan_pos_ = 0;
  }
  auto keep = [&](std::vector<PendingArrival>& list, ArrivalChunks& into) {
    if (!list.empty()) {
      into.push_back(std::move(list));
    } else if (list.capacity() > 0 && spare_chunks_.size() < 4) {
      spare_chunks_.push_back(std::move(list));
    }
    list = {};
  };
  keep(taken_.removes, incoming_removes_);
  keep(taken_.others, incoming_others_);
  taken_.clear();
}

bool Publisher::has_unranked() const {
  auto left = [](const ArrivalChunks& q, std::size_t pos) { return !q.empty() && (q.size() > 1 || pos < q.front().size()); };
  return left(incoming_removes_, removes_pos_) || left(incoming_others_, others_pos_) || rescan_pos_ < rescan_.size();
}

void Publisher::rank_entry(const DesiredState& desired, std::uint32_t index) {
  const PendingArrival a = desired.arrival_of(index);
  if (a.kind == PendingKind::None) return;
  const Candidate c = candidate_of(a);
  (a.kind == PendingKind::Remove ? aged_removes_ : aged_others_).push_back({c.since, c.index, c.seq});
  push_candidate(c);
}

void Publisher::rank_arrivals(const DesiredState& desired, std::uint32_t budget, bool lists, PublishReport& rep) {
  auto rank_list = [&](ArrivalChunks& chunks, std::size_t& pos, detail::Ring<Aged>& aged) {
    for (std::uint32_t n = 0; n < budget; ++n, ++pos, ++rep.ranked) {
      const PendingArrival* a = front_arrival(chunks, pos);
      if (!a) break;
      if (stale(*a)) continue;
      const Candidate c = candidate_of(*a);
      aged.push_back({c.since, c.index, c.seq});
      push_candidate(c);
    }
  };
  if (lists) {
    rank_list(incoming_removes_, removes_pos_, aged_removes_);
    rank_list(incoming_others_, others_pos_, aged_others_);
  }
  // After an overflow: pending entries from the entries themselves.
  for (std::uint32_t n = 0; n < budget && rescan_pos_ < rescan_.size(); ++n, ++rep.ranked)
    rank_entry(desired, rescan_[rescan_pos_++]);
  if (rescan_pos_ >= rescan_.size()) {
    rescan_.clear();
    rescan_pos_ = 0;
  }
}

// A slice of the ranked candidates is scored again for this frame's view and time (and
// cleared of candidates whose pending period ended), walking the queues from the best
// bucket down and round again.
void Publisher::rescore_slice(PublishReport& rep) {
  std::size_t total = 0;
  for (const auto& q : queues_) total += q.size();
  const std::size_t steps = std::min<std::size_t>(config_.rescore_per_frame, total);
  for (std::size_t n = 0; n < steps;) {
    detail::BucketQueue& q = queues_[static_cast<std::size_t>(rescore_queue_)];
    if (rescore_bucket_ < 0 || rescore_item_ >= q.bucket(rescore_bucket_).size()) {
      // The next nonempty bucket below, else the next queue from its top.
      const int next = rescore_bucket_ < 0 ? -1 : q.highest(rescore_bucket_ - 1);
      rescore_item_ = 0;
      if (next >= 0) {
        rescore_bucket_ = next;
      } else {
        rescore_queue_ = (rescore_queue_ + 1) % static_cast<int>(queues_.size());
        rescore_bucket_ = queues_[static_cast<std::size_t>(rescore_queue_)].highest();
        // Empty queues are passed over without counting; `total` > 0 ends the search.
      }
      continue;
    }
    ++n;
    ++rep.touched;
    std::vector<Candidate>& items = q.bucket(rescore_bucket_);
    Candidate& c = items[rescore_item_];
    if (!live(c.index, c.seq)) {
      q.remove_at(rescore_bucket_, rescore_item_);
      continue;
    }
    if (c.kind == PendingKind::Remove) {
      const auto cls = static_cast<std::uint8_t>(remove_class(c.position));
      if (cls != c.remove_class && c.slot != kNoSlot) removes_.set(to_underlying(c.slot), cls, c.index);
      c.remove_class = cls;
    }
    const int b = bucket_of(score(c));
    if (b == rescore_bucket_) {
      ++rescore_item_;
      continue;
    }
    const Candidate moved = c;
    q.remove_at(rescore_bucket_, rescore_item_);
    q.push(moved, b);
  }
}

// The best candidate still pending: from the queue with the highest bucket (ties: removes,
// then updates, then inserts, so equal priorities free slots before filling them). A
// candidate whose priority fell below its bucket since it was scored goes back down
// (up to rescore_per_frame such per frame). An invisible remove stands for any invisible
// remove: the one in the lowest slot goes (they are all alike to the viewer, and slot
// order makes a frame's writes few long ranges).
bool Publisher::pop_best(const DesiredState& desired, std::uint32_t& index, PublishReport& rep) {
  while (pops_left_ > 0) {
    --pops_left_;
    int best_q = -1, best_b = -1;
    for (int q : {kRemoveQueue, kUpdateQueue, kInsertQueue}) {
      const int b = queues_[static_cast<std::size_t>(q)].highest();
      if (b > best_b) {
        best_b = b;
        best_q = q;
      }
    }
    if (best_q < 0) return false;
    detail::BucketQueue& q = queues_[static_cast<std::size_t>(best_q)];
    Candidate c = q.pop(best_b);
    ++rep.touched;
    // The next candidate's entry is a cache miss away in a pool of hundreds of megabytes:
    // ask for it now, so it overlaps this one's checks and publication.
    if (const Candidate* next = q.peek(best_b)) prefetch_entry(desired, next->index);
    if (!live(c.index, c.seq)) continue;
    if (reevaluations_ < config_.rescore_per_frame) {
      const int b = bucket_of(score(c));
      if (b < best_b) {
        ++reevaluations_;
        q.push(c, b);
        continue;
      }
    }
    if (!still_pending(desired, c.index, c.id)) {
      seq_[c.index] = 0;
      continue;
    }
    if (chosen_stamp_[c.index] == round_) continue;  // chosen in this round already
    if (c.kind == PendingKind::Remove && c.remove_class == 0) {
      std::uint32_t slot = 0, other = 0;
      if (removes_.lowest_in(0, slot, other) && other != c.index) {
        // c stays ranked; the lowest invisible remove goes in its place (checked as a spare).
        q.push(c, best_b);
        removes_.clear(slot);
        const DesiredEntry& e = desired.entry(other);
        ++rep.touched;
        if (e.pending_kind() != PendingKind::Remove || e.slot != SlotIndex{slot} || chosen_stamp_[other] == round_) continue;
        index = other;
        return true;
      }
    }
    if (c.kind == PendingKind::Remove && c.slot != kNoSlot) removes_.clear(to_underlying(c.slot));
    index = c.index;
    return true;
  }
  return false;  // the frame's pops are spent (dead candidates crowding the top)
}

void Publisher::collect_escapes(const DesiredState& desired, PublishReport& rep) {
  // Dead items at the fronts are dropped as they come, at most a ranking slice per frame.
  std::uint32_t pops = 0;
  const std::uint32_t max_pops = config_.rescore_per_frame + config_.escape_quota;
  while (chosen_.size() < config_.escape_quota && pops < max_pops) {
    detail::Ring<Aged>* q = nullptr;
    if (!aged_removes_.empty()) q = &aged_removes_;
    if (!aged_others_.empty() && (!q || aged_others_.front().since < q->front().since)) q = &aged_others_;
    if (!q) break;
    const Aged a = q->front();
    if (live(a.index, a.seq) && now_ - a.since < config_.age_escape_s) break;
    q->pop_front();
    ++pops;
    ++rep.touched;
    if (!live(a.index, a.seq) || chosen_stamp_[a.index] == round_) continue;
    if (desired.entry(a.index).pending_kind() == PendingKind::None) continue;
    chosen_stamp_[a.index] = round_;
    chosen_.push_back(a.index);
  }
}

void Publisher::rerank_leftovers(const DesiredState& desired, PublishReport& rep) {
  for (const std::uint32_t i : chosen_) {
    if (desired.entry(i).pending_kind() == PendingKind::None) continue;
    ++rep.touched;
    rank_entry(desired, i);
  }
}

Expected<PublishReport> Publisher::publish(DesiredState& desired, SlotTable& slots, const ViewState& view, double now) {
  PublishReport rep;
  view_ = view;
  now_ = now;
  blocked_ = false;
  reevaluations_ = 0;
  const bool immediate = config_.mode == PublishMode::Immediate;
  const std::uint32_t allowance = immediate ? config_.immediate_allowance : allowance_;
  // Candidates popped this frame, dead ones included: the allowance's worth a few times
  // over, plus the re-evaluations.
  pops_left_ = std::uint64_t{4} * allowance + 2ull * config_.rescore_per_frame + 64;
  rep.allowance = allowance;
  if (removes_.capacity() != slots.capacity()) removes_.reset(slots.capacity());
  if (chosen_stamp_.size() < desired.entry_slots()) chosen_stamp_.resize(desired.entry_slots(), 0);
  if (seq_.size() < desired.entry_slots()) {
    seq_.resize(desired.entry_slots(), 0);
    seen_.resize(desired.entry_slots(), 0);
  }

  take_arrivals(desired);
  const std::uint32_t rank_budget = static_cast<std::uint32_t>(std::max<std::uint64_t>(
      config_.rescore_per_frame, std::uint64_t{config_.rank_allowances} * allowance));
  // Immediate publication serves the lists in arrival order, unscored (only entries
  // rescanned after an overflow are ranked).
  rank_arrivals(desired, rank_budget, !immediate, rep);
  if (!immediate) rescore_slice(rep);

  auto next_round = [&] {
    if (++round_ == 0) {  // wrapped: old stamps could collide
      std::fill(chosen_stamp_.begin(), chosen_stamp_.end(), 0);
      round_ = 1;
    }
  };
  // Age escape first (progressive): the oldest edits past the limit, up to the quota, on
  // top of the allowance.
  next_round();
  chosen_.clear();
  if (!immediate) collect_escapes(desired, rep);
  escaped_ranges_ = 0;
  budget_ = 0.0;  // the escape is on top of the allowance
  if (!chosen_.empty()) {
    Status s = apply_chosen(desired, slots, chosen_, rep);
    if (!s) return s.error();
    rep.escaped = rep.slot_writes();
    escaped_ranges_ = rep.new_ranges;
    rerank_leftovers(desired, rep);
    blocked_ = false;  // an escaped insert that found no room yet does not stop the rest
  }
  const std::uint32_t escaped_ranges = escaped_ranges_;
  auto charged = [&] { return charged_work(rep); };
  // apply_chosen stops at the allowance, even inside a round: a round sized on a guess
  // of how scattered its writes are cannot overrun the frame.
  budget_ = static_cast<double>(allowance);
  // Then the best ranked, up to the allowance. Paired edits (an insert into a leaving
  // Gaussian's slot) cost one write for two edits, and writes next to each other share
  // a range, so a round can leave allowance over; the next round takes the next-best of
  // what is still pending. A round is sized by the share of writes that opened a range
  // (this frame's so far; for the first round the last busy frame's, pessimistic 1
  // before any) so it cannot overrun much.
  auto ranges_full = [&] { return config_.max_new_ranges > 0 && rep.new_ranges >= config_.max_new_ranges; };
  while (!blocked_ && !ranges_full() && charged() < static_cast<double>(allowance)) {
    const std::uint32_t writes = rep.slot_writes() - rep.escaped;
    const double fraction = writes ? static_cast<double>(rep.new_ranges - escaped_ranges) / writes : range_fraction_;
    const double per_write = 1.0 + static_cast<double>(config_.range_cost) * fraction;
    // Rounds of at most kRound: the entries a round pops are still in cache when it
    // publishes them (a round of a whole allowance had them evicted by then).
    constexpr std::size_t kRound = 256;
    const auto room = std::min(kRound, static_cast<std::size_t>(std::max(1.0, (static_cast<double>(allowance) - charged()) / per_write)));
    next_round();
    chosen_.clear();
    std::uint32_t index = 0;
    while (chosen_.size() < room && pop_best(desired, index, rep)) {
      chosen_stamp_[index] = round_;
      chosen_.push_back(index);
    }
    if (chosen_.empty()) break;
    Status s = apply_chosen(desired, slots, chosen_, rep);
    if (!s) return s.error();
    // What the allowance cut off (or found no room for) is ranked again for later frames.
    rerank_leftovers(desired, rep);
  }
  if (immediate && !blocked_ && !ranges_full()) {
    if (Status s = publish_in_arrival_order(desired, slots, rep); !s) return s.error();
  }
  rep.pending_after = static_cast<std::uint32_t>(desired.pending_count());
  for (const auto& q : queues_) rep.backlog += static_cast<std::uint32_t>(q.size());
  if (!immediate) saturated_ = charged() >= static_cast<double>(allowance);
  if (rep.slot_writes() > 0) range_fraction_ = static_cast<double>(rep.new_ranges) / rep.slot_writes();
  return rep;
}

// --- publication -----------------------------------------------------------------------

Status Publisher::publish_pair(DesiredState& desired, SlotTable& slots, std::uint32_t leaving, std::uint32_t entering,
                               PublishReport& rep) {
  const DesiredEntry& e = desired.entry(entering);
  auto s = slots.replace(desired.entry(leaving).id, e.id, e.value);
  if (!s) return s.error();
  forget(desired, leaving, *s);
  forget(desired, entering, *s);
  desired.mark_published(leaving);
  desired.mark_published(entering, *s);
  ++rep.replaced;
  count_range(slots, *s, rep);
  return Ok{};
}

const PendingArrival* Publisher::front_arrival(ArrivalChunks& chunks, std::size_t& pos) {
  while (!chunks.empty()) {
    if (pos < chunks.front().size()) return &chunks.front()[pos];
    retire_chunk(chunks, pos);
  }
  return nullptr;
}

void Publisher::retire_chunk(ArrivalChunks& chunks, std::size_t& pos) {
  if (spare_chunks_.size() < 4) {
    chunks.front().clear();
    spare_chunks_.push_back(std::move(chunks.front()));
  }
  chunks.pop_front();
  pos = 0;
}

// Immediate: what arrived, straight from the arrival lists in their order, without scoring
// (ranking is for choosing, and immediate publication chooses everything): each insert or
// update as it comes, an insert into a full table taking the slot of the next pending remove
// of the removes list, then the removes left. Every arrival is checked against its entry.
Status Publisher::publish_in_arrival_order(DesiredState& desired, SlotTable& slots, PublishReport& rep) {
  constexpr std::size_t kAhead = 8;  // arrivals whose entries are requested ahead of use
  // The next arrival of a list, counted as read; its entry's successors are fetched ahead.
  auto next_of = [&](ArrivalChunks& chunks, std::size_t& pos) -> const PendingArrival* {
    if (pops_left_ == 0) return nullptr;
    const PendingArrival* a = front_arrival(chunks, pos);
    if (!a) return nullptr;
    --pops_left_;
    ++rep.touched;
    if (pos + kAhead < chunks.front().size()) prefetch_entry(desired, chunks.front()[pos + kAhead].index);
    return a;
  };
  // The next pending remove of the removes list, consumed; then ranked ones (earlier
  // progressive frames).
  auto next_remove = [&]() -> std::uint32_t {
    while (const PendingArrival* r = next_of(incoming_removes_, removes_pos_)) {
      const std::uint32_t index = r->index;
      const GaussianId id = r->id;
      ++removes_pos_;
      const DesiredEntry& e = desired.entry(index);
      if (e.id == id && e.pending_kind() == PendingKind::Remove) return index;
    }
    return next_spare_remove(desired, rep);
  };
  while (!over_budget(rep)) {
    const PendingArrival* a = next_of(incoming_others_, others_pos_);
    if (!a) break;
    const std::uint32_t index = a->index;
    const DesiredEntry& e = desired.entry(index);
    const PendingKind kind = e.id == a->id ? e.pending_kind() : PendingKind::None;
    if (kind == PendingKind::Insert && slots.free_count() == 0) {
      const std::uint32_t r = next_remove();
      if (r == DesiredEntry::kNotPending) {
        if (has_unranked()) {
          blocked_ = true;
          return Ok{};
        }
        return Error{"publisher: slot table full and no pending remove to make room"};
      }
      if (Status st = publish_pair(desired, slots, r, index, rep); !st) return st;
    } else if (kind == PendingKind::Insert || kind == PendingKind::Update) {
      if (Status st = publish_entry(desired, slots, index, rep); !st) return st;
    }
    // A remove listed among the others cannot happen (kinds are listed apart); a changed
    // entry listed again is published once and found settled the second time.
    ++others_pos_;
  }
  while (!over_budget(rep)) {
    const std::uint32_t r = next_remove();
    if (r == DesiredEntry::kNotPending) break;
    if (Status st = publish_entry(desired, slots, r, rep); !st) return st;
  }
  return Ok{};
}

// The lowest-class, lowest-slot pending remove not chosen this round, or kNotPending.
std::uint32_t Publisher::next_spare_remove(const DesiredState& desired, PublishReport& rep) {
  std::uint32_t slot = 0, index = 0;
  while (removes_.lowest(slot, index)) {
    removes_.clear(slot);
    ++rep.touched;
    const DesiredEntry& e = desired.entry(index);
    if (e.pending_kind() == PendingKind::Remove && e.slot == SlotIndex{slot} && chosen_stamp_[index] != round_) return index;
  }
  return DesiredEntry::kNotPending;
}

// The best ranked pending insert not chosen this round, or kNotPending.
std::uint32_t Publisher::next_spare_insert(const DesiredState& desired, PublishReport& rep) {
  detail::BucketQueue& q = queues_[kInsertQueue];
  for (int b = q.highest(); b >= 0; b = q.highest()) {
    const Candidate c = q.pop(b);
    ++rep.touched;
    if (!live(c.index, c.seq)) continue;
    if (desired.entry(c.index).id != c.id || desired.entry(c.index).pending_kind() != PendingKind::Insert) continue;
    if (chosen_stamp_[c.index] == round_) continue;
    return c.index;
  }
  return DesiredEntry::kNotPending;
}

// Publishes `chosen`. Chosen inserts pair with chosen removes first (one slot write
// each); an insert finding the table full takes the slot of an unchosen remove (least
// visible first, so what vanishes early is what the viewer is least likely to see;
// among equally visible ones in slot order, so that a frame's inserts land in
// consecutive slots and upload as a few long ranges, not thousands of copy commands);
// a chosen remove left over takes an unchosen insert (most relevant first) rather than
// leaving a hole a later frame refills. With the table full and no remove ranked yet
// while arrivals still wait to be ranked, the insert waits for a later frame (blocked_).
Status Publisher::apply_chosen(DesiredState& desired, SlotTable& slots, const std::vector<std::uint32_t>& chosen,
                               PublishReport& rep) {
  inserts_.clear();
  removes_chosen_.clear();
  for (const std::uint32_t i : chosen) {
    switch (desired.entry(i).pending_kind()) {
      case PendingKind::Insert: inserts_.push_back(i); break;
      case PendingKind::Remove: removes_chosen_.push_back(i); break;
      case PendingKind::Update: {
        if (over_budget(rep)) return Ok{};
        Status s = publish_entry(desired, slots, i, rep);
        if (!s) return s;
        break;
      }
      case PendingKind::None: break;
    }
  }
  auto pair = [&](std::uint32_t leaving, std::uint32_t entering) { return publish_pair(desired, slots, leaving, entering, rep); };
  for (std::size_t n = 0; n < inserts_.size(); ++n) {
    const std::uint32_t ins = inserts_[n];
    if (!removes_chosen_.empty()) {
      const std::uint32_t r = removes_chosen_.back();
      removes_chosen_.pop_back();
      if (over_budget(rep)) return Ok{};
      Status s = pair(r, ins);
      if (!s) return s;
      continue;
    }
    if (slots.free_count() == 0) {
      if (over_budget(rep)) return Ok{};
      const std::uint32_t r = next_spare_remove(desired, rep);
      if (r == DesiredEntry::kNotPending) {
        if (has_unranked()) {
          blocked_ = true;
          return Ok{};
        }
        return Error{"publisher: slot table full and no pending remove to make room"};
      }
      Status s = pair(r, ins);
      if (!s) return s;
      continue;
    }
    if (over_budget(rep)) return Ok{};
    Status s = publish_entry(desired, slots, ins, rep);
    if (!s) return s;
  }
  for (std::size_t n = 0; n < removes_chosen_.size(); ++n) {
    const std::uint32_t r = removes_chosen_[n];
    if (over_budget(rep)) return Ok{};
    const std::uint32_t ins = next_spare_insert(desired, rep);
    Status s = ins != DesiredEntry::kNotPending ? pair(r, ins) : publish_entry(desired, slots, r, rep);
    if (!s) return s;
  }
  return Ok{};
}

void Publisher::report_frame_cost(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0.0) return;  // a broken timer must not steer the allowance
  const double sample = 1.0 - seconds / config_.display_period_s;
  slack_ += config_.slack_smoothing * (sample - slack_);
  // Grow only when the allowance was what limited the last frame: idle frames have
  // plenty of slack, and growing on them would hand the next burst an allowance the
  // display cannot afford.
  if (slack_ > config_.slack_high && saturated_) {
    allowance_ = static_cast<std::uint32_t>(std::min<double>(config_.allowance_max, std::ceil(allowance_ * config_.grow)));
  } else if (slack_ < config_.slack_low) {
    allowance_ = static_cast<std::uint32_t>(std::max<double>(config_.allowance_min, std::floor(allowance_ * config_.shrink)));
  }
}

}  // namespace gauss
