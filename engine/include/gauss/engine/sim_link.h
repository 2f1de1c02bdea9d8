#pragma once
// A modelled network link, one direction, for the deterministic simulation: latency,
// bandwidth and packet loss, with the reliable ordered delivery ENet gives a reliable
// channel. A message (its real encoded bytes) is cut into MTU-sized packets that leave
// one after another at the link's bandwidth; a lost packet is sent again after a
// retransmission timeout and occupies the link again; a message is delivered when all
// its packets have arrived and every earlier message was delivered (head-of-line
// blocking, as in ENet). Seeded: the same seed and traffic give the same times.
#include <cstdint>
#include <deque>
#include <vector>

namespace gauss::sim {

struct LinkConditions {
  double latency_s{0.005};      // one-way propagation delay
  double bandwidth_bps{100e6};  // bits per second
  double loss{0.0};             // packet loss probability in [0, 1)
  // Retransmission timeout: ENet waits about two round trips (RTT + 4 * variance)
  // before resending; modelled as rto_rtt_factor * 2 * latency, at least rto_min_s.
  double rto_rtt_factor{2.0};
  double rto_min_s{0.03};
};

inline constexpr std::uint32_t kLinkMtu = 1400;  // payload bytes per packet (ENet's default MTU)
inline constexpr std::uint32_t kPacketOverhead = 48;  // UDP/IP + ENet headers per packet

struct LinkStats {
  std::uint64_t messages{0};
  std::uint64_t packets{0};
  std::uint64_t retransmissions{0};
  std::uint64_t bytes{0};        // message bytes (payload)
  std::uint64_t wire_bytes{0};   // including headers and retransmissions
};

class Link {
 public:
  explicit Link(std::uint64_t seed, LinkConditions conditions = {});
  void set_conditions(const LinkConditions& c) { cond_ = c; }
  const LinkConditions& conditions() const { return cond_; }
  // Sends `bytes` at time `now`; returns the delivery time at the far end.
  double send(double now, std::uint64_t bytes);
  // Forgets queued traffic (connection dropped): the link is free from `now` on.
  void reset(double now);
  const LinkStats& stats() const { return stats_; }

 private:
  double uniform();
  std::uint64_t state_;
  LinkConditions cond_;
  double link_free_{0.0};       // when the sender's link is next idle
  double last_delivery_{0.0};   // ordered delivery: never before the previous message
  LinkStats stats_;
};

}  // namespace gauss::sim
