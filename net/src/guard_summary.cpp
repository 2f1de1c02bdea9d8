// guard_summary (guard_summary.h).
#include "guard_summary.h"

#include <cstdio>
#include <vector>

#include "gauss/engine/log_text.h"

namespace gauss::net::detail {

namespace {

struct Part {
  std::uint64_t HostCounters::*field;
  const char* what;
};

// "N what, M what" for the fields that grew; empty when none did.
std::string list(const HostCounters& now, const HostCounters& before, const std::vector<Part>& parts) {
  std::string out;
  for (const Part& p : parts) {
    const std::uint64_t d = now.*(p.field) - before.*(p.field);
    if (d == 0) continue;
    if (!out.empty()) out += ", ";
    out += std::to_string(d) + " " + p.what;
  }
  return out;
}

}  // namespace

std::string guard_summary(const HostCounters& now, const HostCounters& before, double seconds) {
  const std::string refused = list(now, before,
                                   {{&HostCounters::refused_token, "wrong proof"},
                                    {&HostCounters::refused_backoff, "waiting after a wrong proof"},
                                    {&HostCounters::refused_proof_rate, "over the proof rate"},
                                    {&HostCounters::refused_session_rate, "over the session rate"},
                                    {&HostCounters::refused_address_full, "address full"},
                                    {&HostCounters::refused_full, "host full"},
                                    {&HostCounters::refused_version, "version"},
                                    {&HostCounters::refused_capacity, "capacity"},
                                    {&HostCounters::refused_malformed, "malformed"}});
  const std::string timed_out = list(now, before,
                                     {{&HostCounters::pending_timeouts, "connect requests never acknowledged"},
                                      {&HostCounters::handshake_timeouts, "without Hello or proof"},
                                      {&HostCounters::refusals_dropped, "refused peers that stayed"}});
  const std::string evicted = list(now, before,
                                   {{&HostCounters::pending_evicted, "unacknowledged"},
                                    {&HostCounters::handshake_evicted, "without Hello"}});
  const std::string kicked = list(now, before,
                                  {{&HostCounters::kicked, "kicked"},
                                   {&HostCounters::stalled, "of them stalled"},
                                   {&HostCounters::malformed, "malformed messages"},
                                   {&HostCounters::wrong_direction, "wrong-direction messages"},
                                   {&HostCounters::message_flood, "over the message rate"},
                                   {&HostCounters::query_flood, "over the query rate"}});
  if (refused.empty() && timed_out.empty() && evicted.empty() && kicked.empty()) return {};
  char head[96];
  std::snprintf(head, sizeof head, "admission, last %.1f s: %llu connections, %llu accepted", seconds,
                static_cast<unsigned long long>(now.connections - before.connections),
                static_cast<unsigned long long>(now.accepted - before.accepted));
  std::string line = head;
  if (!refused.empty()) line += "; refused: " + refused;
  if (!timed_out.empty()) line += "; timed out: " + timed_out;
  if (!evicted.empty()) line += "; dropped early for free slots: " + evicted;
  if (!kicked.empty()) line += "; clients: " + kicked;
  if (!now.last_rejection.empty()) line += "; last: " + escape_for_log(now.last_rejection, 200);
  return line;
}

}  // namespace gauss::net::detail
