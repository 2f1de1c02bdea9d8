#pragma once
// The project's own hostile clients for the admission tests (issue 28), each from its own
// loopback source addresses (127.0.0.2 and up: Linux routes all of 127/8 to lo), so a
// legitimate client on 127.0.0.1 is another address, as an attacker on the same Wi-Fi is:
//   - half_open_burst: connect requests that are never acknowledged (the ENet host that
//     sent them is destroyed at once, as a forged-source flood would never answer);
//   - SilentSwarm: connections that complete ENet's handshake, never send a Hello, and
//     are reopened as soon as the host drops them, on a thread of their own.
#include <atomic>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include <enet/enet.h>

#include "gauss/engine/messages.h"

namespace gauss::test {

// An ENet host bound to 127.0.0.`last_octet` on any free port (nullptr when the address
// cannot be bound).
inline ENetHost* host_on_loopback(int last_octet, std::size_t peers) {
  ENetAddress bind{};
  enet_address_set_host(&bind, ("127.0.0." + std::to_string(last_octet)).c_str());
  bind.port = 0;
  return enet_host_create(&bind, peers, msg::kChannelCount, 0, 0);
}

inline ENetAddress loopback_port(std::uint16_t port) {
  ENetAddress a{};
  enet_address_set_host(&a, "127.0.0.1");
  a.port = port;
  return a;
}

// Sends `per_address` connect requests from each of `addresses` source addresses and
// never answers. Returns the requests sent.
inline std::size_t half_open_burst(std::uint16_t port, int addresses, std::size_t per_address) {
  enet_initialize();
  std::size_t sent = 0;
  const ENetAddress to = loopback_port(port);
  for (int k = 0; k < addresses; ++k) {
    ENetHost* h = host_on_loopback(2 + k, per_address);
    if (h == nullptr) continue;
    for (std::size_t i = 0; i < per_address; ++i)
      if (enet_host_connect(h, &to, msg::kChannelCount, 0) != nullptr) ++sent;
    enet_host_flush(h);
    enet_host_destroy(h);  // resets its peers without a word: nothing is acknowledged
  }
  enet_deinitialize();
  return sent;
}

class SilentSwarm {
 public:
  SilentSwarm(std::uint16_t port, int addresses, std::size_t per_address) {
    enet_initialize();
    const ENetAddress to = loopback_port(port);
    for (int k = 0; k < addresses; ++k) {
      if (ENetHost* h = host_on_loopback(2 + k, per_address)) {
        for (std::size_t i = 0; i < per_address; ++i) enet_host_connect(h, &to, msg::kChannelCount, 0);
        hosts_.push_back(h);
      }
    }
    thread_ = std::thread([this, to] { run(to); });
  }
  ~SilentSwarm() {
    stop_ = true;
    thread_.join();
    for (ENetHost* h : hosts_) enet_host_destroy(h);
    enet_deinitialize();
  }
  SilentSwarm(const SilentSwarm&) = delete;
  SilentSwarm& operator=(const SilentSwarm&) = delete;

  std::uint64_t connects() const { return connects_.load(); }
  std::uint64_t drops() const { return drops_.load(); }

 private:
  void run(ENetAddress to) {
    while (!stop_.load()) {
      for (ENetHost* h : hosts_) {
        ENetEvent ev;
        while (enet_host_service(h, &ev, 0) > 0) {
          if (ev.type == ENET_EVENT_TYPE_CONNECT) ++connects_;
          if (ev.type == ENET_EVENT_TYPE_RECEIVE) enet_packet_destroy(ev.packet);
          if (ev.type == ENET_EVENT_TYPE_DISCONNECT) {
            ++drops_;
            enet_host_connect(h, &to, msg::kChannelCount, 0);  // reopened at once
          }
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }

  std::vector<ENetHost*> hosts_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> connects_{0}, drops_{0};
};

}  // namespace gauss::test
