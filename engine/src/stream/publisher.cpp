#include "gauss/engine/publisher.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <glm/geometric.hpp>

namespace gauss {

Publisher::Publisher(PublisherConfig config) : config_(config) {
  // A config with min > max would make the clamp ill-defined: order the bounds.
  if (config_.allowance_min == 0) config_.allowance_min = 1;
  if (config_.allowance_max < config_.allowance_min) config_.allowance_max = config_.allowance_min;
  allowance_ = std::clamp(config_.allowance_initial, config_.allowance_min, config_.allowance_max);
}

bool Publisher::in_view_cone(const glm::vec3& position, const ViewState& view) const {
  const glm::vec3 d = position - view.eye;
  const float dist = glm::length(d);
  return dist <= 1e-6f || glm::dot(d, view.forward) >= config_.view_cos_half_fov * dist;
}

float Publisher::view_relevance(const DesiredEntry& e, const ViewState& view) const {
  // A remove matters where the published Gaussian is; anything else where it will be.
  const glm::vec3 pos = e.pending_kind() == PendingKind::Remove ? e.published_position : e.value.position;
  const glm::vec3 d = pos - view.eye;
  const float dist = glm::length(d);
  const float c = dist > 1e-6f ? glm::dot(d, view.forward) / dist : 1.0f;
  const float in_view = c >= config_.view_cos_half_fov ? 1.0f : std::max(0.0f, c) * 0.5f;
  const float r = in_view / (1.0f + dist / std::max(config_.view_distance_reference, 1e-3f));
  return std::isfinite(r) ? r : 0.0f;
}

float Publisher::priority(const DesiredEntry& e, const ViewState& view, double now) const {
  // A leaving Gaussian's support says nothing about how urgently it should go, and one
  // outside the view cone is not seen: removes out of view tie (same age, same
  // magnitude), and ties go in slot order (publish()), so they vacate whole runs of slots.
  const bool remove = e.pending_kind() == PendingKind::Remove;
  const float support = remove ? 0.0f
                               : std::min(1.0f, std::log1p(static_cast<float>(e.value.support)) /
                                                    std::log1p(std::max(config_.support_reference, 1.0f)));
  const float relevance = remove && !in_view_cone(e.published_position, view) ? 0.0f : view_relevance(e, view);
  const float age = std::min(1.0f, static_cast<float>(now - e.pending_since) / std::max(config_.age_reference_s, 1e-3f));
  const float p = config_.w_support * support + config_.w_view * relevance + config_.w_magnitude * e.magnitude +
                  config_.w_age * std::max(0.0f, age);
  return std::isfinite(p) ? p : 0.0f;
}

double Publisher::charged_work(const PublishReport& rep) const {
  return static_cast<double>(rep.slot_writes() - rep.escaped) +
         static_cast<double>(config_.range_cost) * static_cast<double>(rep.new_ranges - escaped_ranges_);
}

bool Publisher::over_budget(const PublishReport& rep) const { return budget_ > 0.0 && charged_work(rep) >= budget_; }

void Publisher::count_range(const SlotTable& slots, SlotIndex slot, PublishReport& rep) const {
  if (!(config_.range_cost > 0.0f)) return;
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
      break;
    }
    case PendingKind::Update: {
      Status s = slots.update(e.id, e.value);
      if (!s) return s;
      ++rep.updated;
      count_range(slots, held(), rep);
      break;
    }
    case PendingKind::Insert: {
      auto s = slots.insert(e.id, e.value);
      if (!s) return s.error();
      ++rep.inserted;
      count_range(slots, *s, rep);
      desired.mark_published(index, *s);
      return Ok{};
    }
    case PendingKind::None: return Ok{};
  }
  desired.mark_published(index);
  return Ok{};
}

namespace {

// Priorities are finite and >= 0, so their float bits order like the values; inverted,
// ascending keys are descending priorities.
std::uint64_t selection_key(float priority, SlotIndex slot) {
  std::uint32_t bits = 0;
  static_assert(sizeof(bits) == sizeof(priority));
  std::memcpy(&bits, &priority, sizeof(bits));
  return (static_cast<std::uint64_t>(~bits) << 32) | to_underlying(slot);
}

}  // namespace

Publisher::Ranked Publisher::rank(const DesiredState& desired, const SlotTable& slots, std::uint32_t index,
                                  double now) const {
  const DesiredEntry& e = desired.entry(index);
  Ranked r;
  r.index = index;
  r.kind = e.pending_kind();
  r.id = e.id;
  r.key = selection_key(priority(e, view_, now), e.slot);
  if (r.kind == PendingKind::Remove) {
    // Removes as room for inserts: outside the view cone all alike (bucket 0: none of
    // them is seen), inside it by relevance in 1/16 steps; then by slot.
    const auto bucket = in_view_cone(e.published_position, view_)
                            ? 1 + static_cast<std::uint64_t>(std::min(15.0f, view_relevance(e, view_) * 16.0f))
                            : std::uint64_t{0};
    const SlotIndex slot = e.slot != kNoSlot ? e.slot : slots.slot_of(e.id);
    r.spare_key = (bucket << 32) | to_underlying(slot);
  } else {
    r.spare_key = r.key;
  }
  return r;
}

bool Publisher::still_pending(const DesiredState& desired, std::uint32_t index, GaussianId id) const {
  const DesiredEntry& e = desired.entry(index);
  return e.id == id && e.pending_kind() != PendingKind::None;
}

// Everything pending goes to the backlog (the head refills from it on first use), and
// into the age queue in pending_since order.
void Publisher::rebuild_ranking(const DesiredState& desired, const SlotTable& slots, double now) {
  head_.clear();
  head_pos_ = 0;
  backlog_.clear();
  spare_removes_.clear();
  spare_inserts_.clear();
  by_age_.clear();
  rescore_cursor_ = 0;
  std::vector<Aged> aged;
  aged.reserve(desired.pending().size());
  backlog_.reserve(desired.pending().size());
  for (std::uint32_t i : desired.pending()) {
    backlog_.push_back(rank(desired, slots, i, now));
    aged.push_back({desired.entry(i).pending_since, i, desired.entry(i).id});
  }
  std::sort(aged.begin(), aged.end(), [](const Aged& a, const Aged& b) {
    return a.since != b.since ? a.since < b.since : a.index < b.index;
  });
  by_age_.assign(aged.begin(), aged.end());
  ranked_ = true;
}

void Publisher::update_ranking(DesiredState& desired, const SlotTable& slots, double now) {
  bool overflowed = false;
  desired.take_pending_arrivals(arrivals_, overflowed);
  if (!ranked_ || overflowed) {
    rebuild_ranking(desired, slots, now);
    return;
  }
  // A changed entry is ranked again beside its old item (the old one is skipped or
  // dropped once the entry is published); only a new one joins the age queue.
  for (const std::uint32_t a : arrivals_) {
    const std::uint32_t i = a & ~DesiredState::kArrivalChanged;
    const DesiredEntry& e = desired.entry(i);
    if (e.pending_kind() == PendingKind::None) continue;
    backlog_.push_back(rank(desired, slots, i, now));
    if (!(a & DesiredState::kArrivalChanged)) by_age_.push_back({e.pending_since, i, e.id});
  }
  // The head, what gets published next, follows the view: re-scored when the view moved.
  const bool moved = glm::distance(view_.eye, head_view_.eye) > 0.01f || glm::dot(view_.forward, head_view_.forward) < 0.99996f;
  if (moved) rescore_head(desired, slots, now);
  // A slice of the backlog is re-scored (and cleared of what stopped being pending).
  const std::size_t slice = std::min<std::size_t>(config_.rescore_per_frame, backlog_.size());
  for (std::size_t n = 0; n < slice && !backlog_.empty(); ++n) {
    if (rescore_cursor_ >= backlog_.size()) rescore_cursor_ = 0;
    Ranked& r = backlog_[rescore_cursor_];
    if (!still_pending(desired, r.index, r.id)) {
      r = backlog_.back();
      backlog_.pop_back();
      continue;
    }
    r = rank(desired, slots, r.index, now);
    ++rescore_cursor_;
  }
  // The age queue holds dead items only until they reach its front; keep it near the
  // pending count so a long stream of short-lived edits cannot grow it without bound.
  if (by_age_.size() > 2 * desired.pending_count() + 4096)
    std::erase_if(by_age_, [&](const Aged& a) { return !still_pending(desired, a.index, a.id); });
}

void Publisher::rescore_head(const DesiredState& desired, const SlotTable& slots, double now) {
  std::size_t live = head_pos_;
  for (std::size_t k = head_pos_; k < head_.size(); ++k)
    if (still_pending(desired, head_[k].index, head_[k].id)) head_[live++] = rank(desired, slots, head_[k].index, now);
  head_.resize(live);
  std::sort(head_.begin() + static_cast<std::ptrdiff_t>(head_pos_), head_.end(), before);
  head_view_ = view_;
}

// Moves the best of the backlog (by its possibly stale keys) into the head, sorted.
bool Publisher::refill_head(const DesiredState& desired) {
  head_.erase(head_.begin(), head_.begin() + static_cast<std::ptrdiff_t>(head_pos_));
  head_pos_ = 0;
  const std::size_t want = std::max<std::size_t>(1024, static_cast<std::size_t>(allowance_) * std::max(1u, config_.head_allowances));
  // Spare removes (moved out of the backlog as room for inserts) compete again once the
  // backlog cannot fill the head: when no insert is left to need them, nothing else would
  // ever take them. (Returned only then: each return costs the next refill_spares a pass.)
  if (backlog_.size() < want && !spare_removes_.empty()) {
    backlog_.insert(backlog_.end(), spare_removes_.begin(), spare_removes_.end());
    spare_removes_.clear();
  }
  auto later = [](const Ranked& a, const Ranked& b) { return before(b, a); };
  while (head_.size() < want && !backlog_.empty()) {
    const std::size_t take = std::min(want - head_.size(), backlog_.size());
    // The `take` best at the back of the backlog, then moved over.
    if (take < backlog_.size())
      std::nth_element(backlog_.begin(), backlog_.end() - static_cast<std::ptrdiff_t>(take), backlog_.end(), later);
    for (std::size_t k = backlog_.size() - take; k < backlog_.size(); ++k)
      if (still_pending(desired, backlog_[k].index, backlog_[k].id)) head_.push_back(backlog_[k]);
    backlog_.resize(backlog_.size() - take);
  }
  rescore_cursor_ = 0;
  std::sort(head_.begin(), head_.end(), before);
  return !head_.empty();
}

// Lists spare removes (room for inserts) or spare inserts (partners for removes): the
// `need` best, at least a head's worth, the best at the back. Spare removes move out of
// the backlog (the unused ones go back at the next refill), so ones used up as room never
// come round again; spare inserts, needed only when chosen removes outnumber chosen
// inserts, are copies of the best pending inserts, checked as they are listed.
void Publisher::refill_spares(const DesiredState& desired, PendingKind kind, std::size_t need) {
  const std::size_t keep = std::max<std::size_t>(need, static_cast<std::size_t>(allowance_) * std::max(1u, config_.head_allowances));
  auto better = [](const Ranked& a, const Ranked& b) {
    return a.spare_key != b.spare_key ? a.spare_key < b.spare_key : a.index < b.index;
  };
  std::vector<Ranked>& out = kind == PendingKind::Remove ? spare_removes_ : spare_inserts_;
  auto gather = [&](const std::vector<Ranked>& from, std::size_t begin) {
    for (std::size_t k = begin; k < from.size(); ++k)
      if (from[k].kind == kind && still_pending(desired, from[k].index, from[k].id) &&
          desired.entry(from[k].index).pending_kind() == kind)
        out.push_back(from[k]);
  };
  if (kind == PendingKind::Remove) {
    backlog_.insert(backlog_.end(), out.begin(), out.end());
    out.clear();
    // Only live removes may compete: the backlog also holds items that stopped being
    // pending (published, or their entry re-ranked as another kind), and these, picked by
    // their keys among the best, would crowd the live ones out of the `take` selected and
    // leave an insert with no room although removes are pending. Dead items go for good.
    std::erase_if(backlog_, [&](const Ranked& r) { return !still_pending(desired, r.index, r.id); });
    const auto first = std::partition(backlog_.begin(), backlog_.end(), [&](const Ranked& r) {
      return r.kind != PendingKind::Remove || desired.entry(r.index).pending_kind() != PendingKind::Remove;
    });
    const std::size_t removes = static_cast<std::size_t>(backlog_.end() - first);
    const std::size_t take = std::min(keep, removes);
    if (take < removes)
      std::nth_element(first, backlog_.end() - static_cast<std::ptrdiff_t>(take), backlog_.end(),
                       [&](const Ranked& a, const Ranked& b) { return better(b, a); });
    out.assign(backlog_.end() - static_cast<std::ptrdiff_t>(take), backlog_.end());
    backlog_.resize(backlog_.size() - take);
    rescore_cursor_ = 0;
    std::erase_if(out, [&](const Ranked& r) {
      return !still_pending(desired, r.index, r.id) || desired.entry(r.index).pending_kind() != kind;
    });
    // The backlog had none left: what is pending is in the head (copies; the head skips
    // them once published).
    if (out.empty()) gather(head_, head_pos_);
  } else {
    out.clear();
    gather(head_, head_pos_);
    gather(backlog_, 0);
  }
  if (out.size() > keep) {
    std::nth_element(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(keep), out.end(), better);
    out.resize(keep);
  }
  std::sort(out.begin(), out.end(), [&](const Ranked& a, const Ranked& b) { return better(b, a); });
}

// The next spare of `kind` still pending as that kind, or kNotPending when none is left.
std::uint32_t Publisher::next_spare(const DesiredState& desired, PendingKind kind, std::size_t need) {
  std::vector<Ranked>& list = kind == PendingKind::Remove ? spare_removes_ : spare_inserts_;
  for (int pass = 0; pass < 2; ++pass) {
    while (!list.empty()) {
      const Ranked r = list.back();
      list.pop_back();
      if (still_pending(desired, r.index, r.id) && desired.entry(r.index).pending_kind() == kind) return r.index;
    }
    if (pass == 0) refill_spares(desired, kind, need);
  }
  return DesiredEntry::kNotPending;
}

Expected<PublishReport> Publisher::publish(DesiredState& desired, SlotTable& slots, const ViewState& view, double now) {
  PublishReport rep;
  view_ = view;
  if (config_.mode == PublishMode::Immediate) {
    // Everything is chosen: no unchosen candidate is ever ranked, so no priorities.
    ranked_ = false;  // rebuilt if progressive publication resumes
    bool overflowed = false;
    desired.take_pending_arrivals(arrivals_, overflowed);
    spare_removes_.clear();
    spare_inserts_.clear();
    budget_ = 0.0;
    chosen_.assign(desired.pending().begin(), desired.pending().end());
    Status s = apply_chosen(desired, slots, chosen_, rep);
    if (!s) return s.error();
    rep.pending_after = static_cast<std::uint32_t>(desired.pending_count());
    return rep;
  }
  rep.allowance = allowance_;
  update_ranking(desired, slots, now);
  if (chosen_stamp_.size() < desired.entry_slots()) chosen_stamp_.resize(desired.entry_slots(), 0);
  auto next_round = [&] {
    if (++round_ == 0) {  // wrapped: old stamps could collide
      std::fill(chosen_stamp_.begin(), chosen_stamp_.end(), 0);
      round_ = 1;
    }
  };
  // Age escape first: the oldest edits past the limit, up to the quota, on top of the allowance.
  next_round();
  chosen_.clear();
  while (!by_age_.empty() && chosen_.size() < config_.escape_quota) {
    const Aged a = by_age_.front();
    const DesiredEntry& e = desired.entry(a.index);
    // Published since, or pending again (queued again then), or listed twice.
    if (!still_pending(desired, a.index, a.id) || e.pending_since != a.since || chosen_stamp_[a.index] == round_) {
      by_age_.pop_front();
      continue;
    }
    if (now - a.since < config_.age_escape_s) break;
    by_age_.pop_front();
    chosen_stamp_[a.index] = round_;
    chosen_.push_back(a.index);
  }
  escaped_ranges_ = 0;
  budget_ = 0.0;  // the escape is on top of the allowance
  if (!chosen_.empty()) {
    Status s = apply_chosen(desired, slots, chosen_, rep);
    if (!s) return s.error();
    rep.escaped = rep.slot_writes();
    escaped_ranges_ = rep.new_ranges;
  }
  const std::uint32_t escaped_ranges = escaped_ranges_;
  auto charged = [&] { return charged_work(rep); };
  // apply_chosen stops at the allowance, even inside a round: a round sized on a guess
  // of how scattered its writes are cannot overrun the frame.
  budget_ = static_cast<double>(allowance_);
  // Then the best ranked, up to the allowance. Paired edits (an insert into a leaving
  // Gaussian's slot) cost one write for two edits, and writes next to each other share
  // a range, so a round can leave allowance over; the next round takes the next-best of
  // what is still pending. A round is sized by the share of writes that opened a range
  // (this frame's so far; for the first round the last busy frame's, pessimistic 1
  // before any) so it cannot overrun much.
  while (charged() < static_cast<double>(allowance_)) {
    const std::uint32_t writes = rep.slot_writes() - rep.escaped;
    const double fraction = writes ? static_cast<double>(rep.new_ranges - escaped_ranges) / writes : range_fraction_;
    const double per_write = 1.0 + static_cast<double>(config_.range_cost) * fraction;
    const auto room = static_cast<std::size_t>(std::max(1.0, (static_cast<double>(allowance_) - charged()) / per_write));
    next_round();
    chosen_.clear();
    while (chosen_.size() < room) {
      if (head_pos_ == head_.size() && !refill_head(desired)) break;
      const Ranked& r = head_[head_pos_++];
      if (!still_pending(desired, r.index, r.id) || chosen_stamp_[r.index] == round_) continue;
      chosen_stamp_[r.index] = round_;
      chosen_.push_back(r.index);
    }
    if (chosen_.empty()) break;
    Status s = apply_chosen(desired, slots, chosen_, rep);
    if (!s) return s.error();
  }
  // What the allowance cut off this frame stays at the front of the head.
  {
    std::vector<Ranked> left;
    for (std::uint32_t i : chosen_)
      if (still_pending(desired, i, desired.entry(i).id)) left.push_back(rank(desired, slots, i, now));
    if (!left.empty()) {
      std::sort(left.begin(), left.end(), before);
      head_.insert(head_.begin() + static_cast<std::ptrdiff_t>(head_pos_), left.begin(), left.end());
    }
  }
  rep.pending_after = static_cast<std::uint32_t>(desired.pending_count());
  saturated_ = charged() >= static_cast<double>(allowance_);
  if (rep.slot_writes() > 0) range_fraction_ = static_cast<double>(rep.new_ranges) / rep.slot_writes();
  return rep;
}

// Publishes `chosen`. Chosen inserts pair with chosen removes first (one slot write
// each); an insert finding the table full takes the slot of an unchosen remove (least
// visible first, so what vanishes early is what the viewer is least likely to see;
// among equally visible ones in slot order, so that a frame's inserts land in
// consecutive slots and upload as a few long ranges, not thousands of copy commands);
// a chosen remove left over takes an unchosen insert (most relevant first) rather than
// leaving a hole a later frame refills. In immediate mode everything is chosen, so no
// unchosen spare exists: spares come from the progressive ranking only.
Status Publisher::apply_chosen(DesiredState& desired, SlotTable& slots, const std::vector<std::uint32_t>& chosen,
                               PublishReport& rep) {
  const bool spares = config_.mode == PublishMode::Progressive;
  std::vector<std::uint32_t> inserts, removes;
  for (const std::uint32_t i : chosen) {
    switch (desired.entry(i).pending_kind()) {
      case PendingKind::Insert: inserts.push_back(i); break;
      case PendingKind::Remove: removes.push_back(i); break;
      case PendingKind::Update: {
        if (over_budget(rep)) return Ok{};
        Status s = publish_entry(desired, slots, i, rep);
        if (!s) return s;
        break;
      }
      case PendingKind::None: break;
    }
  }
  auto pair = [&](std::uint32_t leaving, std::uint32_t entering) -> Status {
    const DesiredEntry& e = desired.entry(entering);
    auto s = slots.replace(desired.entry(leaving).id, e.id, e.value);
    if (!s) return s.error();
    desired.mark_published(leaving);
    desired.mark_published(entering, *s);
    ++rep.replaced;
    count_range(slots, *s, rep);
    return Ok{};
  };
  for (std::size_t n = 0; n < inserts.size(); ++n) {
    const std::uint32_t ins = inserts[n];
    if (!removes.empty()) {
      const std::uint32_t r = removes.back();
      removes.pop_back();
      if (over_budget(rep)) return Ok{};
      Status s = pair(r, ins);
      if (!s) return s;
      continue;
    }
    if (slots.free_count() == 0) {
      if (over_budget(rep)) return Ok{};
      const std::uint32_t r = spares ? next_spare(desired, PendingKind::Remove, inserts.size() - n) : DesiredEntry::kNotPending;
      if (r == DesiredEntry::kNotPending) return Error{"publisher: slot table full and no pending remove to make room"};
      Status s = pair(r, ins);
      if (!s) return s;
      continue;
    }
    if (over_budget(rep)) return Ok{};
    Status s = publish_entry(desired, slots, ins, rep);
    if (!s) return s;
  }
  for (std::size_t n = 0; n < removes.size(); ++n) {
    const std::uint32_t r = removes[n];
    if (over_budget(rep)) return Ok{};
    const std::uint32_t ins = spares ? next_spare(desired, PendingKind::Insert, removes.size() - n) : DesiredEntry::kNotPending;
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
