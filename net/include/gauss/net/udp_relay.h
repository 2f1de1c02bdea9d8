#pragma once
// UdpRelay: a small lossy UDP forwarder for tests, standing in for netem (these
// machines have no netem qdisc and ENet has no loss simulator). Clients connect to
// the relay's port; each distinct client address gets its own upstream socket to the
// real host (like a NAT), and every datagram in either direction passes a seeded
// policy: dropped, delayed (base + jitter, which also reorders), or duplicated.
// The same seed and traffic give the same decisions.
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>

#include "gauss/engine/result.h"
#include "gauss/net/address.h"

namespace gauss::net {

struct RelayPolicy {
  std::uint64_t seed{1};
  double loss{0.0};                        // probability a datagram is dropped, [0, 1)
  double duplicate{0.0};                   // probability a datagram is delivered twice, [0, 1]
  std::chrono::microseconds delay{0};      // one-way base delay
  std::chrono::microseconds jitter{0};     // extra uniform delay in [0, jitter): reorders datagrams
  std::size_t max_queued{1u << 16};        // datagrams in flight beyond this are dropped
  // Client-to-host datagrams for which this returns true are dropped, every time (a
  // retransmission carries the same bytes): a test's way to lose one message for good and
  // leave a gap in a reliable channel. Not counted as loss: `filtered`.
  std::function<bool(std::span<const std::uint8_t>)> drop_to_host;
};

struct RelayCounters {
  std::uint64_t received{0};
  std::uint64_t delivered{0};
  std::uint64_t dropped{0};      // by the loss policy
  std::uint64_t filtered{0};     // by drop_to_host
  std::uint64_t duplicated{0};
  std::uint64_t overflow{0};     // queue full
  std::uint64_t reordered{0};    // delivered before a datagram that arrived earlier
  std::uint64_t sessions{0};     // distinct client addresses seen
};

class UdpRelay {
 public:
  // Listens on `listen` (port 0: any free port) and forwards to `upstream`.
  // Fails on a bad policy or a socket error, naming it.
  static Expected<std::unique_ptr<UdpRelay>> start(const Endpoint& listen, const Endpoint& upstream, RelayPolicy policy);
  ~UdpRelay();
  UdpRelay(const UdpRelay&) = delete;
  UdpRelay& operator=(const UdpRelay&) = delete;

  std::uint16_t port() const noexcept;
  // Replaces the policy (loss, delay...) for datagrams arriving from now on; the RNG
  // keeps its state so a run stays reproducible from its seed and schedule.
  void set_policy(const RelayPolicy& policy);
  RelayCounters counters() const;

 private:
  struct Impl;
  explicit UdpRelay(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace gauss::net
