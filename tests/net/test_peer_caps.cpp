// Resource bounds per peer on the host's transport, each a test:
//   - a client flooding messages is cut off at the transport (message_flood, then kicked)
//     while another client's messages keep reaching the policy;
//   - a packet larger than a peer's incoming buffer (1 MiB: clients only send small
//     control messages) is never delivered, and the host keeps serving;
//   - half-open connections (connected, no Hello) are bounded by the peer limit
//     (max_clients + admission.spare_peers) and expire after the handshake timeout (or
//     earlier, to keep a reserve of slots free), after which a real client gets in.
// (test_hostile_clients.cpp runs the bigger attacks of issue 28.)
// (A connection that stays silent, and one that only sends garbage, are tested in
// test_transport.cpp.) No timing assertions: every wait is on a condition.
#include <chrono>
#include <cstdio>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

#include <enet/enet.h>
#include <gtest/gtest.h>

#include "gauss/engine/wire.h"
#include "gauss/net/client.h"
#include "gauss/net/host.h"
#include "null_sink.h"
#include "raw_peer.h"

namespace gauss {
namespace {

using namespace std::chrono_literals;

net::NetHostConfig quiet_host() {
  net::NetHostConfig c;
  c.bind.port = 0;
  c.log = [](const std::string&) {};
  return c;
}

net::NetClientConfig client_to(std::uint16_t port, const std::string& name) {
  net::NetClientConfig c;
  c.server = {"127.0.0.1", port};
  c.slot_capacity = 100;
  c.name = name;
  c.reconnect = false;
  c.log = [](const std::string&) {};
  return c;
}

using test::wait_until;

// Welcomes every new connection and counts the messages per client.
struct Policy {
  explicit Policy(net::NetHost& h) : host(h) {}
  void pump() {
    for (auto& e : host.poll()) {
      if (e.kind == net::HostEventKind::Connected) {
        EXPECT_TRUE(host.send(e.client, msg::Welcome{msg::kProtocolVersion, host.session_id(), e.client, 100}).ok());
        names[e.client] = e.hello.client_name;
      } else if (e.kind == net::HostEventKind::Message) {
        ++messages[names[e.client]];
      }
    }
  }
  net::NetHost& host;
  std::map<std::uint32_t, std::string> names;
  std::map<std::string, std::uint64_t> messages;
};

TEST(PeerCaps, AMessageFloodIsCutOffWhileOtherClientsGetThrough) {
  auto cfg = quiet_host();
  cfg.message_rate_hz = 50.0;
  cfg.message_burst = 100.0;
  cfg.max_rejected_per_client = 300;
  auto host = net::NetHost::start(cfg);
  ASSERT_TRUE(host.ok()) << host.message();
  Policy policy(**host);
  test::NullSink flood_sink, calm_sink;
  auto flood = net::NetClient::start(client_to((*host)->port(), "flood"), flood_sink);
  auto calm = net::NetClient::start(client_to((*host)->port(), "calm"), calm_sink);
  ASSERT_TRUE(flood.ok() && calm.ok());
  ASSERT_TRUE(wait_until([&] {
    policy.pump();
    return (*flood)->status() == net::ClientStatus::Connected && (*calm)->status() == net::ClientStatus::Connected;
  }));
  const auto t0 = std::chrono::steady_clock::now();
  msg::HeadPose pose;
  for (int i = 0; i < 2000; ++i) {
    pose.sequence = static_cast<std::uint32_t>(i + 1);
    ASSERT_TRUE((*flood)->send(pose).ok());
  }
  // The flood is rejected past the bucket and the flooder is disconnected.
  ASSERT_TRUE(wait_until([&] {
    policy.pump();
    return (*host)->counters().kicked == 1;
  })) << (*host)->counters().last_rejection;
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto hc = (*host)->counters();
  EXPECT_GT(hc.message_flood, 300u);
  EXPECT_LE(static_cast<double>(policy.messages["flood"]), 100.0 + 50.0 * elapsed + 1.0)
      << "no more than the bucket reached the policy";
  // The calm client, same host, same time: its messages arrive.
  for (int i = 0; i < 5; ++i) ASSERT_TRUE((*calm)->send(msg::Ack{}).ok());
  ASSERT_TRUE(wait_until([&] {
    policy.pump();
    return policy.messages["calm"] >= 5;
  }));
  EXPECT_EQ((*calm)->status(), net::ClientStatus::Connected);
  EXPECT_EQ(hc.events_dropped, 0u);
}

// ENet peers opened by hand, all from one local ENet host: they connect and never speak.
class RawPeers {
 public:
  RawPeers(std::uint16_t port, std::size_t count) {
    enet_initialize();
    host_ = enet_host_create(nullptr, count, msg::kChannelCount, 0, 0);
    ENetAddress a{};
    enet_address_set_host(&a, "127.0.0.1");
    a.port = port;
    for (std::size_t i = 0; i < count; ++i) peers_.push_back(enet_host_connect(host_, &a, msg::kChannelCount, 0));
  }
  ~RawPeers() {
    enet_host_destroy(host_);
    enet_deinitialize();
  }
  // Services the local host for `d`; returns the connects and disconnects seen so far.
  void service(std::chrono::milliseconds d) {
    ENetEvent ev;
    const auto until = std::chrono::steady_clock::now() + d;
    while (std::chrono::steady_clock::now() < until) {
      if (enet_host_service(host_, &ev, 5) <= 0) continue;
      if (ev.type == ENET_EVENT_TYPE_CONNECT) ++connected;
      if (ev.type == ENET_EVENT_TYPE_DISCONNECT) ++disconnected;
      if (ev.type == ENET_EVENT_TYPE_RECEIVE) enet_packet_destroy(ev.packet);
    }
  }
  void send(std::size_t peer, const std::vector<std::uint8_t>& bytes) {
    enet_peer_send(peers_[peer], 0, enet_packet_create(bytes.data(), bytes.size(), ENET_PACKET_FLAG_RELIABLE));
    enet_host_flush(host_);
  }
  int connected{0}, disconnected{0};

 private:
  ENetHost* host_{nullptr};
  std::vector<ENetPeer*> peers_;
};

TEST(PeerCaps, HalfOpenConnectionsAreBoundedAndExpire) {
  auto cfg = quiet_host();
  cfg.max_clients = 2;  // ENet peer limit: max_clients + spare_peers = 18
  cfg.admission.spare_peers = 16;
  cfg.handshake_timeout = 500ms;
  auto host = net::NetHost::start(cfg);
  ASSERT_TRUE(host.ok()) << host.message();
  RawPeers raw((*host)->port(), 40);
  // At most the peer limit gets in; the rest wait in vain (their connects go unanswered).
  raw.service(300ms);  // less than the handshake timeout: nothing expired yet
  EXPECT_LE((*host)->counters().connections, 18u);
  EXPECT_LE(raw.connected, 18);
  EXPECT_GT(raw.connected, 0);
  const auto t0 = std::chrono::steady_clock::now();
  auto dropped = [&] {
    const auto c = (*host)->counters();
    return c.handshake_timeouts + c.handshake_evicted;
  };
  while (std::chrono::steady_clock::now() - t0 < 3s && dropped() < 18) raw.service(50ms);
  const auto hc = (*host)->counters();
  std::printf("half-open: %llu connections, %llu expired, %llu dropped early, local side saw %d connects\n",
              static_cast<unsigned long long>(hc.connections), static_cast<unsigned long long>(hc.handshake_timeouts),
              static_cast<unsigned long long>(hc.handshake_evicted), raw.connected);
  EXPECT_GE(hc.handshake_timeouts + hc.handshake_evicted, 18u);
  EXPECT_EQ(hc.accepted, 0u);
  // Once the half-open connections expired, a real client gets in.
  Policy policy(**host);
  test::NullSink sink;
  auto client = net::NetClient::start(client_to((*host)->port(), "real"), sink);
  ASSERT_TRUE(client.ok());
  ASSERT_TRUE(wait_until([&] {
    raw.service(10ms);  // keep the raw peers' side alive: they may retry
    policy.pump();
    return (*client)->status() == net::ClientStatus::Connected;
  })) << "a real client could not connect after the half-open flood";
}

TEST(PeerCaps, AnOversizedPacketIsNeverDeliveredAndTheHostKeepsServing) {
  auto host = net::NetHost::start(quiet_host());
  ASSERT_TRUE(host.ok()) << host.message();
  Policy policy(**host);
  RawPeers raw((*host)->port(), 1);
  ASSERT_TRUE(wait_until([&] {
    raw.service(10ms);
    return raw.connected == 1;
  }));
  msg::Hello hello;
  hello.slot_capacity = 100;
  hello.client_name = "big";
  raw.send(0, wire::encode(hello).value());
  ASSERT_TRUE(wait_until([&] {
    raw.service(10ms);
    policy.pump();
    return (*host)->counters().accepted == 1;
  }));
  // 4 MiB in one reliable packet: four times what one peer may make the host buffer.
  raw.send(0, std::vector<std::uint8_t>(std::size_t{4} << 20, 0x5A));
  raw.service(1500ms);
  policy.pump();
  // Delivered, it would be counted (a malformed frame) and its bytes received.
  const auto hc = (*host)->counters();
  EXPECT_EQ(hc.malformed, 0u) << "the oversized packet was reassembled and delivered";
  EXPECT_LT(hc.bytes_received, std::uint64_t{1} << 20);
  EXPECT_EQ(policy.messages["big"], 0u);
  // The host still serves: another client connects and its message arrives.
  test::NullSink sink;
  auto client = net::NetClient::start(client_to((*host)->port(), "next"), sink);
  ASSERT_TRUE(client.ok());
  ASSERT_TRUE(wait_until([&] {
    raw.service(5ms);
    policy.pump();
    return (*client)->status() == net::ClientStatus::Connected;
  }));
  ASSERT_TRUE((*client)->send(msg::Ack{}).ok());
  ASSERT_TRUE(wait_until([&] {
    raw.service(5ms);
    policy.pump();
    return policy.messages["next"] >= 1;
  }));
}

}  // namespace
}  // namespace gauss
