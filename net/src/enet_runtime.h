#pragma once
// Process-wide ENet initialisation shared by every host, client and test in a
// process: enet_initialize once on first use, enet_deinitialize after the last
// user goes. Also the helpers both ends use to create an ENet host.
#include <cstddef>
#include <string>

#include <enet/enet.h>

#include "gauss/engine/result.h"
#include "gauss/net/address.h"

namespace gauss::net::detail {

class EnetRuntime {
 public:
  // Fails when enet_initialize fails (no socket layer).
  static Status acquire();
  static void release();
};

// Holds one runtime reference for an object's lifetime.
class EnetRef {
 public:
  EnetRef() = default;
  EnetRef(const EnetRef&) = delete;
  EnetRef& operator=(const EnetRef&) = delete;
  ~EnetRef() {
    if (held_) EnetRuntime::release();
  }
  Status acquire() {
    auto s = EnetRuntime::acquire();
    held_ = s.ok();
    return s;
  }

 private:
  bool held_{false};
};

Expected<ENetAddress> resolve(const Endpoint& e);
// Creates an ENet host with the schema's channel count. ENet's packet limit follows
// msg::kMaxMessageBytes (it applies to sending and receiving alike), so a whole
// edit batch always fits; `max_waiting_bytes` bounds what one peer can make this
// end buffer while reassembling incoming packets.
Expected<ENetHost*> create_host(const ENetAddress* bind, std::size_t peers, std::size_t max_waiting_bytes);

// Incoming buffer per client on the host: clients only send small control messages
// (the largest, a Hello, is under 1 KiB), so 1 MiB is generous and keeps a hostile
// peer from parking up to a whole message limit of fragments per connection.
inline constexpr std::size_t kHostWaitingBytesPerPeer = std::size_t{1} << 20;

}  // namespace gauss::net::detail
