#pragma once
// Process-wide ENet initialisation shared by every host, client and test in a
// process: enet_initialize once on first use, enet_deinitialize after the last
// user goes. Also the helpers both ends use to create an ENet host.
#include <cstddef>
#include <string>

#include <enet/enet.h>

#include "gauss/engine/messages.h"
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
// edit batch always fits (the host lowers it for receiving: kHostIncomingPacketBytes);
// `max_waiting_bytes` bounds the packets one peer can have this end hold undelivered
// (checked before each new packet, so one packet of up to the packet limit still fits).
Expected<ENetHost*> create_host(const ENetAddress* bind, std::size_t peers, std::size_t max_waiting_bytes);

// Incoming buffer per client on the host: clients only send small control messages
// (the largest, a Hello, is under 1 KiB), so 1 MiB is generous and keeps a hostile
// peer from parking up to a whole message limit of fragments per connection.
inline constexpr std::size_t kHostWaitingBytesPerPeer = std::size_t{1} << 20;

// The largest packet the host accepts from a client. ENet checks maximumPacketSize both
// when a packet is queued for sending and when the first fragment of an incoming one
// arrives (and then allocates the whole declared length, whatever the waiting-data
// limit says), so a host that left it at the message limit would let each peer make it
// allocate 64 MiB with one forged fragment. The host therefore keeps this small limit
// while it services the socket and raises it only while its service thread queues its
// own packets (HostSendLimit).
inline constexpr std::size_t kHostIncomingPacketBytes = std::size_t{64} << 10;

// Raises the host's packet limit to the message limit for the sends made in its scope.
// Service thread only (the only thread touching ENet).
class HostSendLimit {
 public:
  explicit HostSendLimit(ENetHost* host) : host_(host) { host_->maximumPacketSize = msg::kMaxMessageBytes; }
  ~HostSendLimit() { host_->maximumPacketSize = kHostIncomingPacketBytes; }
  HostSendLimit(const HostSendLimit&) = delete;
  HostSendLimit& operator=(const HostSendLimit&) = delete;

 private:
  ENetHost* host_;
};

}  // namespace gauss::net::detail
