#pragma once
// Helpers shared by the transport tests: a raw ENet peer that does not run NetClient
// (its first message is whatever the test sends: garbage, forged or replayed Hellos,
// hand-sealed frames), and a bounded wait on a condition (no timing assertions).
#include <chrono>
#include <functional>
#include <optional>
#include <thread>
#include <vector>

#include <enet/enet.h>

#include "gauss/engine/wire.h"

namespace gauss::test {

inline bool wait_until(const std::function<bool()>& pred, std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < until) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return pred();
}

// An ENet host on 127.0.0.1, any free port, that a test drives by hand: a rogue host a
// client connects to (enet_initialize() first; the caller destroys it).
inline ENetHost* rogue_host_on_loopback() {
  ENetAddress bind{};
  enet_address_set_host(&bind, "127.0.0.1");
  bind.port = 0;
  return enet_host_create(&bind, 4, msg::kChannelCount, 0, 0);
}

class RawPeer {
 public:
  explicit RawPeer(std::uint16_t port) {
    enet_initialize();
    host_ = enet_host_create(nullptr, 1, msg::kChannelCount, 0, 0);
    ENetAddress a{};
    enet_address_set_host(&a, "127.0.0.1");
    a.port = port;
    peer_ = enet_host_connect(host_, &a, msg::kChannelCount, 0);
    ENetEvent ev;
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (!connected_ && std::chrono::steady_clock::now() < until)
      if (enet_host_service(host_, &ev, 10) > 0 && ev.type == ENET_EVENT_TYPE_CONNECT) connected_ = true;
  }
  ~RawPeer() {
    enet_host_destroy(host_);
    enet_deinitialize();
  }
  RawPeer(const RawPeer&) = delete;
  RawPeer& operator=(const RawPeer&) = delete;

  bool connected() const { return connected_; }
  void send(const std::vector<std::uint8_t>& bytes) {
    enet_peer_send(peer_, 0, enet_packet_create(bytes.data(), bytes.size(), ENET_PACKET_FLAG_RELIABLE));
    enet_host_flush(host_);
  }
  // The next packet's bytes as they crossed the wire (nullopt: none within the timeout,
  // or a disconnect).
  std::optional<std::vector<std::uint8_t>> receive_packet() {
    ENetEvent ev;
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (std::chrono::steady_clock::now() < until) {
      if (enet_host_service(host_, &ev, 10) <= 0) continue;
      if (ev.type == ENET_EVENT_TYPE_DISCONNECT) return std::nullopt;
      if (ev.type != ENET_EVENT_TYPE_RECEIVE) continue;
      std::vector<std::uint8_t> out(ev.packet->data, ev.packet->data + ev.packet->dataLength);
      enet_packet_destroy(ev.packet);
      return out;
    }
    return std::nullopt;
  }
  // The next message the host sends that decodes (nullopt: none in time, or a disconnect).
  std::optional<wire::Message> receive_one() {
    while (auto p = receive_packet()) {
      auto m = wire::decode(*p);
      if (m.ok()) return std::move(m).value();
    }
    return std::nullopt;
  }
  // Receives until the host disconnects; returns the decoded Refuse, if any came.
  std::optional<msg::Refuse> refuse_then_disconnect() {
    std::optional<msg::Refuse> refuse;
    while (auto p = receive_packet()) {
      auto m = wire::decode(*p);
      if (m.ok() && std::holds_alternative<msg::Refuse>(m.value())) refuse = std::get<msg::Refuse>(m.value());
    }
    return refuse;
  }
  // Services the connection for `d`, dropping what arrives.
  void service(std::chrono::milliseconds d) {
    ENetEvent ev;
    const auto until = std::chrono::steady_clock::now() + d;
    while (std::chrono::steady_clock::now() < until)
      if (enet_host_service(host_, &ev, 5) > 0 && ev.type == ENET_EVENT_TYPE_RECEIVE) enet_packet_destroy(ev.packet);
  }

 private:
  ENetHost* host_{nullptr};
  ENetPeer* peer_{nullptr};
  bool connected_{false};
};

}  // namespace gauss::test
