// AdmissionGuard (admission.h): per-address backoff, session buckets and client counts,
// and the host-wide proof bucket.
#include "gauss/net/admission.h"

#include <algorithm>

namespace gauss::net {

namespace {

// A failure streak is forgotten after this many times the longest wait without a new
// failure: an address that stopped guessing starts again from the shortest wait.
constexpr int kForgetAfterMaxWaits = 4;

double seconds(AdmissionGuard::Clock::duration d) { return std::chrono::duration<double>(d).count(); }

}  // namespace

std::string validate(const AdmissionConfig& c) {
  if (c.spare_peers < 8 || c.spare_peers > 4000) return "spare_peers outside 8..4000";
  if (c.max_peers_per_address == 0) return "max_peers_per_address must be at least 1";
  if (c.max_clients_per_address == 0) return "max_clients_per_address must be at least 1";
  if (c.pending_timeout.count() <= 0) return "pending_timeout must be positive";
  if (c.auth_backoff_initial.count() < 0 || c.auth_backoff_max < c.auth_backoff_initial)
    return "auth_backoff_initial must be >= 0 and <= auth_backoff_max";
  if (!(c.proofs_per_second > 0.0) || !(c.proof_burst >= 1.0))
    return "proofs_per_second must be > 0 and proof_burst >= 1";
  if (!(c.session_open_rate_hz > 0.0) || !(c.session_open_burst >= 1.0))
    return "session_open_rate_hz must be > 0 and session_open_burst >= 1";
  if (c.stall_timeout.count() <= 0) return "stall_timeout must be positive";
  if (c.summary_interval.count() <= 0) return "summary_interval must be positive";
  if (c.tracked_addresses < 16) return "tracked_addresses must be at least 16";
  return {};
}

AdmissionGuard::AdmissionGuard(AdmissionConfig config) : cfg_(config), proof_tokens_(config.proof_burst) {}

AdmissionGuard::Entry& AdmissionGuard::entry(Address a, Clock::time_point now) {
  auto it = entries_.find(a);
  if (it == entries_.end()) {
    if (entries_.size() >= cfg_.tracked_addresses) forget_idle(now);
    Entry e;
    e.session_tokens = cfg_.session_open_burst;
    e.refilled = now;
    it = entries_.emplace(a, e).first;
  }
  it->second.touched = now;
  return it->second;
}

void AdmissionGuard::forget_idle(Clock::time_point now) {
  // Idle: no client, not waiting, its bucket refilled. Those go first; if every entry is
  // busy (thousands of addresses at once), the least recently seen without a client goes,
  // so the table stays bounded and a connected client's count is never lost.
  const double refill_s = cfg_.session_open_burst / cfg_.session_open_rate_hz;
  std::erase_if(entries_, [&](const auto& kv) {
    const Entry& e = kv.second;
    return e.clients == 0 && now >= e.blocked_until && seconds(now - e.refilled) >= refill_s;
  });
  if (entries_.size() < cfg_.tracked_addresses) return;
  auto oldest = entries_.end();
  for (auto it = entries_.begin(); it != entries_.end(); ++it)
    if (it->second.clients == 0 && (oldest == entries_.end() || it->second.touched < oldest->second.touched))
      oldest = it;
  if (oldest != entries_.end()) entries_.erase(oldest);
}

std::optional<AdmissionGuard::Clock::duration> AdmissionGuard::auth_blocked(Address a, Clock::time_point now) const {
  auto it = entries_.find(a);
  if (it == entries_.end() || now >= it->second.blocked_until) return std::nullopt;
  return it->second.blocked_until - now;
}

bool AdmissionGuard::take_proof(Clock::time_point now) {
  if (proofs_started_)
    proof_tokens_ = std::min(cfg_.proof_burst, proof_tokens_ + seconds(now - proofs_refilled_) * cfg_.proofs_per_second);
  proofs_started_ = true;
  proofs_refilled_ = now;
  if (proof_tokens_ < 1.0) return false;
  proof_tokens_ -= 1.0;
  return true;
}

void AdmissionGuard::auth_failed(Address a, Clock::time_point now) {
  Entry& e = entry(a, now);
  if (e.failures > 0 && now - e.last_failure > kForgetAfterMaxWaits * cfg_.auth_backoff_max) e.failures = 0;
  e.failures = std::min<std::uint32_t>(e.failures + 1, 62);
  e.last_failure = now;
  // initial * 2^(failures-1), capped; computed in the duration's ticks without overflow.
  auto wait = cfg_.auth_backoff_initial;
  for (std::uint32_t i = 1; i < e.failures && wait < cfg_.auth_backoff_max; ++i) wait *= 2;
  e.blocked_until = now + std::min(wait, cfg_.auth_backoff_max);
}

void AdmissionGuard::auth_passed(Address a) {
  auto it = entries_.find(a);
  if (it == entries_.end()) return;
  it->second.failures = 0;
  it->second.blocked_until = {};
}

AdmissionGuard::Open AdmissionGuard::open_session(Address a, Clock::time_point now) {
  Entry& e = entry(a, now);
  e.session_tokens =
      std::min(cfg_.session_open_burst, e.session_tokens + seconds(now - e.refilled) * cfg_.session_open_rate_hz);
  e.refilled = now;
  if (e.clients >= cfg_.max_clients_per_address) return Open::AddressFull;
  if (e.session_tokens < 1.0) return Open::RateLimited;
  e.session_tokens -= 1.0;
  ++e.clients;
  return Open::Ok;
}

void AdmissionGuard::client_closed(Address a) {
  auto it = entries_.find(a);
  if (it != entries_.end() && it->second.clients > 0) --it->second.clients;
}

}  // namespace gauss::net
