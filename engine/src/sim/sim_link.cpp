#include "gauss/engine/sim_link.h"

#include <algorithm>

namespace gauss::sim {

Link::Link(std::uint64_t seed, LinkConditions conditions) : state_(seed * 0x9e3779b97f4a7c15ull + 1), cond_(conditions) {}

// splitmix64: tiny, seedable, identical on every platform (std distributions are not).
double Link::uniform() {
  std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * (1.0 / 9007199254740992.0);
}

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
