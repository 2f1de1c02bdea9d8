#include "gauss/engine/sim_link.h"

#include <algorithm>

#include "stream/splitmix.h"

namespace gauss::sim {

Link::Link(std::uint64_t seed, LinkConditions conditions) : state_(seed * kSplitmixGamma + 1), cond_(conditions) {}

double Link::uniform() { return unit_double(splitmix64_next(state_)); }

double Link::send(double now, std::uint64_t bytes) {
  ++stats_.messages;
  stats_.bytes += bytes;
  const double bw = std::max(cond_.bandwidth_bps, 1e3);
  const double loss = std::clamp(cond_.loss, 0.0, 0.95);
  const double rto = std::max(cond_.rto_min_s, cond_.rto_rtt_factor * 2.0 * cond_.latency_s);
  double arrival = now;
  std::uint64_t left = std::max<std::uint64_t>(bytes, 1);
  while (left > 0) {
    const std::uint64_t chunk = std::min<std::uint64_t>(left, kLinkMtu);
    left -= chunk;
    const double tx = static_cast<double>(chunk + kPacketOverhead) * 8.0 / bw;
    double t = now;
    for (;;) {
      const double depart = std::max(t, link_free_);
      link_free_ = depart + tx;
      ++stats_.packets;
      stats_.wire_bytes += chunk + kPacketOverhead;
      if (uniform() >= loss) {
        arrival = std::max(arrival, depart + tx + cond_.latency_s);
        break;
      }
      ++stats_.retransmissions;
      t = depart + rto;  // the sender notices the missing acknowledgement and resends
    }
  }
  last_delivery_ = std::max(last_delivery_, arrival);
  return last_delivery_;
}

void Link::reset(double now) {
  link_free_ = now;
  last_delivery_ = now;
}

}  // namespace gauss::sim
