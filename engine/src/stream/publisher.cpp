#include "gauss/engine/publisher.h"

#include <algorithm>
#include <cmath>

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

Expected<PublishReport> Publisher::publish(DesiredState& desired, SlotTable& slots, const ViewState& view, double now) {
  PublishReport rep;
  const std::vector<std::uint32_t>& pending = desired.pending();
  scratch_.assign(pending.begin(), pending.end());
  view_ = view;
  if (config_.mode == PublishMode::Immediate) {
    // Everything is chosen: no unchosen candidate is ever ranked, so no priorities.
    budget_ = 0.0;
    Status s = apply_chosen(desired, slots, 0, scratch_.size(), rep);
    if (!s) return s.error();
    rep.pending_after = static_cast<std::uint32_t>(desired.pending_count());
    return rep;
  }
  rep.allowance = allowance_;
  prio_.resize(desired.entry_slots());
  for (std::uint32_t i : scratch_) prio_[i] = priority(desired.entry(i), view, now);
  // Age escape first: the oldest edits past the limit, up to the quota, on top of the allowance.
  auto old_end = std::partition(scratch_.begin(), scratch_.end(), [&](std::uint32_t i) {
    return now - desired.entry(i).pending_since >= config_.age_escape_s;
  });
  std::size_t escaped = static_cast<std::size_t>(old_end - scratch_.begin());
  if (escaped > config_.escape_quota) {
    std::nth_element(scratch_.begin(), scratch_.begin() + config_.escape_quota, old_end, [&](std::uint32_t a, std::uint32_t b) {
      return desired.entry(a).pending_since < desired.entry(b).pending_since;
    });
    escaped = config_.escape_quota;
  }
  escaped_ranges_ = 0;
  budget_ = 0.0;  // the escape is on top of the allowance
  if (escaped > 0) {
    Status s = apply_chosen(desired, slots, 0, escaped, rep);
    if (!s) return s.error();
    rep.escaped = rep.slot_writes();
    escaped_ranges_ = rep.new_ranges;
  }
  const std::uint32_t escaped_ranges = escaped_ranges_;
  auto charged = [&] { return charged_work(rep); };
  // apply_chosen stops at the allowance, even inside a round: a round sized on a guess
  // of how scattered its writes are cannot overrun the frame.
  budget_ = static_cast<double>(allowance_);
  // Then the highest priorities, up to the allowance. Paired edits (an insert into a
  // leaving Gaussian's slot) cost one write for two edits, and writes next to each
  // other share a range, so a round can leave allowance over; the next round takes the
  // next-best of what is still pending. A round is sized by the share of writes that
  // opened a range (this frame's so far; for the first round the last busy frame's,
  // pessimistic 1 before any) so it cannot overrun much.
  std::size_t pos = escaped;
  while (charged() < static_cast<double>(allowance_)) {
    auto live_end = std::partition(scratch_.begin() + static_cast<std::ptrdiff_t>(pos), scratch_.end(),
                                   [&](std::uint32_t i) { return desired.entry(i).pending_kind() != PendingKind::None; });
    const std::size_t live = static_cast<std::size_t>(live_end - scratch_.begin()) - pos;
    if (live == 0) break;
    scratch_.resize(pos + live);
    const std::uint32_t writes = rep.slot_writes() - rep.escaped;
    const double fraction = writes ? static_cast<double>(rep.new_ranges - escaped_ranges) / writes : range_fraction_;
    const double per_write = 1.0 + static_cast<double>(config_.range_cost) * fraction;
    const auto room = static_cast<std::size_t>(std::max(1.0, (static_cast<double>(allowance_) - charged()) / per_write));
    const std::size_t take = std::min<std::size_t>(live, room);
    if (take < live)
      std::nth_element(scratch_.begin() + static_cast<std::ptrdiff_t>(pos), scratch_.begin() + static_cast<std::ptrdiff_t>(pos + take),
                       scratch_.end(), [&](std::uint32_t a, std::uint32_t b) {
                         if (prio_[a] != prio_[b]) return prio_[a] > prio_[b];
                         // Equal priority: lower slot first (inserts have none: entry order).
                         const auto sa = to_underlying(desired.entry(a).slot), sb = to_underlying(desired.entry(b).slot);
                         return sa != sb ? sa < sb : a < b;
                       });
    Status s = apply_chosen(desired, slots, pos, pos + take, rep);
    if (!s) return s.error();
    pos += take;
  }
  rep.pending_after = static_cast<std::uint32_t>(desired.pending_count());
  saturated_ = charged() >= static_cast<double>(allowance_);
  if (rep.slot_writes() > 0) range_fraction_ = static_cast<double>(rep.new_ranges) / rep.slot_writes();
  return rep;
}

// Publishes scratch_[begin, end). Chosen inserts pair with chosen removes first (one
// slot write each); an insert finding the table full takes the slot of an unchosen
// remove (least visible first, so what vanishes early is what the viewer is least
// likely to see; among equally visible ones in slot order, so that a frame's inserts
// land in consecutive slots and upload as a few long ranges, not thousands of copy
// commands); a chosen remove left over takes an unchosen insert (most relevant first)
// rather than leaving a hole a later frame refills. Unchosen candidates come from
// scratch_[end, size); only as many as can be used are ordered.
Status Publisher::apply_chosen(DesiredState& desired, SlotTable& slots, std::size_t begin, std::size_t end,
                               PublishReport& rep) {
  std::vector<std::uint32_t> inserts, removes;
  for (std::size_t k = begin; k < end; ++k) {
    const std::uint32_t i = scratch_[k];
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
  // Unchosen removes, the `need` to use first at the back: outside the view cone all
  // alike (bucket 0: none of them is seen), inside it by relevance in 1/16 steps; then
  // by slot.
  auto spare_removes_for = [&](std::size_t need) {
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed;
    for (std::size_t k = end; k < scratch_.size(); ++k) {
      const DesiredEntry& e = desired.entry(scratch_[k]);
      if (e.pending_kind() != PendingKind::Remove) continue;
      const auto bucket = in_view_cone(e.published_position, view_)
                              ? 1 + static_cast<std::uint64_t>(std::min(15.0f, view_relevance(e, view_) * 16.0f))
                              : std::uint64_t{0};
      const SlotIndex slot = e.slot != kNoSlot ? e.slot : slots.slot_of(e.id);
      keyed.emplace_back((bucket << 32) | to_underlying(slot), scratch_[k]);
    }
    if (keyed.size() > need) {
      std::nth_element(keyed.begin(), keyed.begin() + static_cast<std::ptrdiff_t>(need), keyed.end());
      keyed.resize(need);
    }
    std::sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    std::vector<std::uint32_t> out;
    out.reserve(keyed.size());
    for (const auto& k : keyed) out.push_back(k.second);
    return out;
  };
  // Unchosen inserts, the `need` most relevant, the most relevant at the back.
  auto spare_inserts_for = [&](std::size_t need) {
    std::vector<std::uint32_t> out;
    for (std::size_t k = end; k < scratch_.size(); ++k)
      if (desired.entry(scratch_[k]).pending_kind() == PendingKind::Insert) out.push_back(scratch_[k]);
    auto higher = [&](std::uint32_t a, std::uint32_t b) { return prio_[a] > prio_[b]; };
    if (out.size() > need) {
      std::nth_element(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(need), out.end(), higher);
      out.resize(need);
    }
    std::sort(out.begin(), out.end(), [&](std::uint32_t a, std::uint32_t b) { return higher(b, a); });
    return out;
  };
  std::vector<std::uint32_t> spare_removes;
  bool spare_removes_listed = false;
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
      if (!spare_removes_listed) {
        spare_removes = spare_removes_for(inserts.size() - n);
        spare_removes_listed = true;
      }
      if (spare_removes.empty()) return Error{"publisher: slot table full and no pending remove to make room"};
      const std::uint32_t r = spare_removes.back();
      spare_removes.pop_back();
      if (over_budget(rep)) return Ok{};
      Status s = pair(r, ins);
      if (!s) return s;
      continue;
    }
    if (over_budget(rep)) return Ok{};
    Status s = publish_entry(desired, slots, ins, rep);
    if (!s) return s;
  }
  std::vector<std::uint32_t> spare_inserts;
  if (!removes.empty()) spare_inserts = spare_inserts_for(removes.size());
  for (std::uint32_t r : removes) {
    if (!spare_inserts.empty()) {
      const std::uint32_t ins = spare_inserts.back();
      spare_inserts.pop_back();
      if (over_budget(rep)) return Ok{};
      Status s = pair(r, ins);
      if (!s) return s;
      continue;
    }
    if (over_budget(rep)) return Ok{};
    Status s = publish_entry(desired, slots, r, rep);
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
