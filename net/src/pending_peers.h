#pragma once
// The host's view of ENet peers still in ENet's own connect handshake: a connect request
// was answered (VERIFY_CONNECT) and its acknowledgement has not come. The application
// never hears of these (no CONNECT event yet), yet each holds a peer slot until ENet gives
// up on the verify, 30 s by default: one burst of forged connect requests (no reply needed,
// so the source addresses may be spoofed) held every slot that long (issue 28, finding 1).
// PendingPeers remembers when each slot became pending (by connect id, so a slot reused
// by another request starts afresh) and resets the ones that outstay `timeout`, silently:
// whoever sent the request may not exist. Service thread only.
#include <chrono>
#include <cstddef>
#include <vector>

#include <enet/enet.h>

namespace gauss::net::detail {

class PendingPeers {
 public:
  using Clock = std::chrono::steady_clock;

  struct Sweep {
    std::size_t timed_out{0};  // pending longer than the timeout, reset
    std::size_t free{0};       // slots free afterwards
  };

  // Resets the pending peers older than `timeout`.
  Sweep sweep(ENetHost* host, Clock::time_point now, Clock::duration timeout);
  // Resets up to `count` pending peers, the oldest first, pending at least `grace` (a
  // legitimate client acknowledges within a round trip, so under a flood the oldest are
  // the forged ones). Returns how many went.
  std::size_t evict_oldest(ENetHost* host, Clock::time_point now, Clock::duration grace, std::size_t count);

 private:
  struct Seen {
    enet_uint32 connect_id{0};
    Clock::time_point since{};
    bool pending{false};
  };
  std::vector<Seen> seen_;  // one per peer slot
};

}  // namespace gauss::net::detail
