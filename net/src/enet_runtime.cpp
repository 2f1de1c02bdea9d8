#include "enet_runtime.h"

#include <mutex>

#include "gauss/engine/messages.h"

namespace gauss::net::detail {
namespace {
std::mutex g_mutex;
int g_users = 0;
}  // namespace

Status EnetRuntime::acquire() {
  std::lock_guard lock(g_mutex);
  if (g_users == 0 && enet_initialize() != 0) return Error{"ENet: enet_initialize failed"};
  ++g_users;
  return Ok{};
}

void EnetRuntime::release() {
  std::lock_guard lock(g_mutex);
  if (g_users > 0 && --g_users == 0) enet_deinitialize();
}

Expected<ENetAddress> resolve(const Endpoint& e) {
  ENetAddress a{};
  a.port = e.port;
  if (enet_address_set_host(&a, e.host.c_str()) != 0)
    return Error{"ENet: cannot resolve host '" + e.host + "'"};
  return a;
}

Expected<ENetHost*> create_host(const ENetAddress* bind, std::size_t peers, std::size_t max_waiting_bytes) {
  ENetHost* h = enet_host_create(bind, peers, msg::kChannelCount, 0, 0);
  if (h == nullptr) {
    if (bind == nullptr) return Error{"ENet: cannot create a client host"};
    return Error{"ENet: cannot bind port " + std::to_string(bind->port) + " (in use or not permitted)"};
  }
  h->maximumPacketSize = msg::kMaxMessageBytes;
  h->maximumWaitingData = max_waiting_bytes;
  return h;
}

}  // namespace gauss::net::detail
