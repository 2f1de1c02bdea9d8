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
// Creates an ENet host with the schema's channel count and packet limits: ENet's
// packet and waiting-data limits follow msg::kMaxMessageBytes, so a whole edit
// batch always fits and a peer cannot make ENet buffer more than two of them.
Expected<ENetHost*> create_host(const ENetAddress* bind, std::size_t peers);

}  // namespace gauss::net::detail
