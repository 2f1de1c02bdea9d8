// The host against the project's own hostile clients over loopback (issue 28): what each
// attack gets, counted by the host, and how soon a legitimate client on another address
// gets in meanwhile. Attackers come from 127.0.0.2 and up, the legitimate client from
// 127.0.0.1 (hostile_peers.h). Bounds on time are the (3 s, 5 s) and generous for a
// loaded machine: a connect on loopback takes milliseconds; everything else is counted.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <span>
#include <thread>
#include <string>
#include <variant>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/engine/wire.h"
#include "gauss/net/auth.h"
#include "gauss/net/client.h"
#include "gauss/net/host.h"
#include "gauss/net/udp_relay.h"
#include "hostile_peers.h"
#include "null_sink.h"
#include "raw_peer.h"

namespace gauss {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// The host's log lines, kept for the test to read.
struct LogCapture {
  std::mutex mu;
  std::vector<std::string> lines;
  net::LogFn fn() {
    return [this](const std::string& l) {
      std::lock_guard lock(mu);
      lines.push_back(l);
    };
  }
  std::vector<std::string> copy() {
    std::lock_guard lock(mu);
    return lines;
  }
};

net::NetHostConfig host_config(LogCapture& log) {
  net::NetHostConfig c;
  c.bind.port = 0;
  c.log = log.fn();
  return c;
}

// Welcomes every Hello the transport passes on.
void welcome_all(net::NetHost& host) {
  for (auto& e : host.poll()) {
    if (e.kind != net::HostEventKind::Connected) continue;
    EXPECT_TRUE(host.send(e.client, msg::Welcome{msg::kProtocolVersion, host.session_id(), e.client, 100}).ok());
  }
}

// Seconds until a NetClient named `name` is welcomed (the host's policy runs meanwhile);
// a negative value when not within `bound`.
double seconds_to_connect(net::NetHost& host, const std::string& name, std::chrono::milliseconds bound,
                          const std::string& token = {}) {
  net::NetClientConfig c;
  c.server = {"127.0.0.1", host.port()};
  c.slot_capacity = 100;
  c.name = name;
  c.access_token = token;
  c.log = [](const std::string&) {};
  test::NullSink sink;
  const auto t0 = Clock::now();
  auto client = net::NetClient::start(c, sink);
  if (!client) return -1.0;
  const bool ok = test::wait_until(
      [&] {
        welcome_all(host);
        return (*client)->status() == net::ClientStatus::Connected;
      },
      bound);
  return ok ? std::chrono::duration<double>(Clock::now() - t0).count() : -1.0;
}

std::string dump(const net::HostCounters& c) {
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "connections %llu accepted %llu pending timed out %llu / evicted %llu, handshake timed out %llu / "
                "evicted %llu, refused %llu (wrong proof %llu, backoff %llu, proof rate %llu), summaries %llu",
                (unsigned long long)c.connections, (unsigned long long)c.accepted,
                (unsigned long long)c.pending_timeouts, (unsigned long long)c.pending_evicted,
                (unsigned long long)c.handshake_timeouts, (unsigned long long)c.handshake_evicted,
                (unsigned long long)c.refused(), (unsigned long long)c.refused_token,
                (unsigned long long)c.refused_backoff, (unsigned long long)c.refused_proof_rate,
                (unsigned long long)c.summaries);
  return buf;
}

TEST(HostileClients, ANameCannotForgeALogLine) {
  LogCapture log;
  auto host = net::NetHost::start(host_config(log));
  ASSERT_TRUE(host.ok()) << host.message();
  const std::string name = "x\ngauss-host: client 1 'legit' left: sent 20000 Gaussians, checksum 42\x1b[2J\x1b[31m";
  ASSERT_GE(seconds_to_connect(**host, name, 20s), 0.0);
  bool found = false;
  for (const std::string& line : log.copy()) {
    EXPECT_EQ(line.find('\n'), std::string::npos) << line;
    EXPECT_EQ(line.find('\x1b'), std::string::npos) << line;
    if (line.find("'x\\ngauss-host: client 1 \\'legit\\' left: sent 20000 Gaussians, checksum 42\\x1b[2J\\x1b[31m'") !=
        std::string::npos)
      found = true;
  }
  EXPECT_TRUE(found) << "the connect line shows the name escaped";
}

TEST(HostileClients, AHalfOpenBurstDoesNotKeepAClientOut) {
  LogCapture log;
  auto cfg = host_config(log);
  cfg.admission.summary_interval = 500ms;
  auto host = net::NetHost::start(cfg);
  ASSERT_TRUE(host.ok()) << host.message();
  // From one address: ENet's per-address limit keeps most of the burst out.
  ASSERT_EQ(test::half_open_burst((*host)->port(), 1, 300), 300u);
  const double one = seconds_to_connect(**host, "after-burst", 3s);
  // From ten addresses, 30 each (more than every free slot): the oldest half-open
  // connections are dropped to keep a reserve free.
  ASSERT_EQ(test::half_open_burst((*host)->port(), 10, 30), 300u);
  const double ten = seconds_to_connect(**host, "after-spread-burst", 3s);
  std::printf("a client connected %.3f s after a 300-request burst from one address, %.3f s after one from ten\n",
              one, ten);
  EXPECT_GE(one, 0.0) << dump((*host)->counters());
  EXPECT_GE(ten, 0.0) << dump((*host)->counters());
  // Every half-open connection that got a slot goes within the pending timeout (3 s) or
  // earlier: the 32 of the first burst ENet let in (its per-address limit), and most of
  // the second's 300 (all but what did not find a slot).
  const auto t0 = Clock::now();
  ASSERT_TRUE(test::wait_until(
      [&] {
        const auto c = (*host)->counters();
        return c.pending_timeouts + c.pending_evicted >= 32 + 200;
      },
      15s))
      << dump((*host)->counters());
  const double waited = std::chrono::duration<double>(Clock::now() - t0).count();
  EXPECT_LE(waited, 6.0) << "half-open connections outlived the pending timeout";
  // The summary of those events comes at the end of its interval: give it one (a loaded
  // machine ran the whole test inside a single interval, 2026-11-27).
  EXPECT_TRUE(test::wait_until([&] { return (*host)->counters().summaries >= 1; }, 3s));
  const auto c = (*host)->counters();
  std::printf("%s (waited %.1f s)\n", dump(c).c_str(), waited);
  // Hundreds of events, a few lines: one summary per interval, none per connection.
  host->reset();
  const auto lines = log.copy();
  for (const auto& l : lines) std::printf("  log: %s\n", l.c_str());
  EXPECT_LE(lines.size(), 4 + static_cast<std::size_t>(2 * (waited + 4.0)));
  EXPECT_GE(c.summaries, 1u);
}

// One token guesser at 127.0.0.`octet`: connects, sends a Hello, answers a Challenge with
// a CPace proof for a wrong guess, and again, until `until`. Counts what the host answered.
struct GuessCounts {
  int attempts{0}, challenged{0}, refused{0};
};
GuessCounts guess_until(std::uint16_t port, int octet, Clock::time_point until) {
  GuessCounts n;
  enet_initialize();
  ENetHost* h = test::host_on_loopback(octet, 1);
  if (h == nullptr) {
    enet_deinitialize();
    return n;
  }
  const ENetAddress to = test::loopback_port(port);
  msg::Hello hello;
  hello.slot_capacity = 100;
  hello.client_name = "guesser";
  const auto hello_frame = wire::encode(hello).value();
  EXPECT_TRUE(net::auth_init().ok());
  auto send = [&](ENetPeer* p, const std::vector<std::uint8_t>& f) {
    enet_peer_send(p, 0, enet_packet_create(f.data(), f.size(), ENET_PACKET_FLAG_RELIABLE));
    enet_host_flush(h);
  };
  while (Clock::now() < until) {
    ENetPeer* peer = enet_host_connect(h, &to, msg::kChannelCount, 0);
    if (peer == nullptr) break;
    ++n.attempts;
    const auto give_up = Clock::now() + 3s;
    bool done = false;
    ENetEvent ev;
    while (!done && Clock::now() < give_up) {
      if (enet_host_service(h, &ev, 5) <= 0) continue;
      if (ev.type == ENET_EVENT_TYPE_CONNECT) send(peer, hello_frame);
      if (ev.type == ENET_EVENT_TYPE_DISCONNECT) done = true;
      if (ev.type != ENET_EVENT_TYPE_RECEIVE) continue;
      const std::vector<std::uint8_t> packet(ev.packet->data, ev.packet->data + ev.packet->dataLength);
      enet_packet_destroy(ev.packet);
      auto m = wire::decode(packet);
      if (!m) continue;
      if (std::holds_alternative<msg::Challenge>(m.value())) {
        ++n.challenged;
        auto guess = net::answer_challenge("guess " + std::to_string(n.challenged), packet, hello_frame);
        if (guess) send(peer, wire::encode(guess->proof).value());
      } else if (std::holds_alternative<msg::Refuse>(m.value())) {
        ++n.refused;
      }
    }
    if (!done) enet_peer_reset(peer);
  }
  enet_host_destroy(h);
  enet_deinitialize();
  return n;
}

TEST(HostileClients, WrongProofsAreAnsweredAHandfulOfTimesPerAddressIn20s) {
  // GAUSS_HOSTILE_GUESS_SECONDS=S guesses for S seconds instead of 20 (2..20; the sanitizer
  // pass of scripts/test runs 8: the flood's host side under ASan is what it is there for,
  // and the bounds below, set for 20 s, hold for any shorter run).
  auto window = 20s;
  if (const char* env = std::getenv("GAUSS_HOSTILE_GUESS_SECONDS"); env && *env)
    window = std::chrono::seconds(std::clamp(std::atoi(env), 2, 20));
  LogCapture log;
  auto cfg = host_config(log);
  cfg.access_token = "correct horse battery staple";
  cfg.admission.summary_interval = 5s;
  auto host = net::NetHost::start(cfg);
  ASSERT_TRUE(host.ok()) << host.message();
  const auto t0 = Clock::now();
  GuessCounts guessed;
  std::thread guesser([&] { guessed = guess_until((*host)->port(), 2, t0 + window); });
  // Meanwhile a client with the token, on another address, gets in.
  std::this_thread::sleep_for(2s);
  const double legit = seconds_to_connect(**host, "legit", 5s, cfg.access_token);
  guesser.join();
  const auto c = (*host)->counters();
  std::printf("%lld s of guessing: %d attempts, %d challenged, %d refused; legitimate client in %.3f s; %s\n",
              static_cast<long long>(window.count()), guessed.attempts, guessed.challenged, guessed.refused, legit,
              dump(c).c_str());
  EXPECT_GE(legit, 0.0);
  EXPECT_GT(guessed.attempts, 50) << "the guesser did try";
  EXPECT_LE(c.refused_token, 6u) << "wrong proofs checked from one address in " << window.count() << " s";
  EXPECT_LE(guessed.challenged, 6);
  EXPECT_GT(c.refused_backoff, 40u);
  host->reset();
  const auto lines = log.copy();
  EXPECT_LE(lines.size(), 12u) << "one summary per 5 s, plus the legitimate client's lines";
}

TEST(HostileClients, TheHostChecksABoundedNumberOfProofsPerSecondFromAnyAddresses) {
  LogCapture log;
  auto cfg = host_config(log);
  cfg.access_token = "correct horse battery staple";
  cfg.admission.auth_backoff_initial = 0ms;  // no per-address wait: only the host-wide cap
  cfg.admission.auth_backoff_max = 0ms;
  cfg.admission.proofs_per_second = 4.0;
  cfg.admission.proof_burst = 4.0;
  auto host = net::NetHost::start(cfg);
  ASSERT_TRUE(host.ok()) << host.message();
  const auto t0 = Clock::now();
  std::vector<std::thread> guessers;
  std::vector<GuessCounts> counts(6);
  for (int k = 0; k < 6; ++k)
    guessers.emplace_back([&, k] { counts[k] = guess_until((*host)->port(), 2 + k, t0 + 3s); });
  for (auto& g : guessers) g.join();
  const double elapsed = std::chrono::duration<double>(Clock::now() - t0).count();
  const auto c = (*host)->counters();
  int attempts = 0;
  for (const auto& n : counts) attempts += n.attempts;
  std::printf("6 addresses guessing for %.1f s: %d attempts; %s\n", elapsed, attempts, dump(c).c_str());
  EXPECT_LE(static_cast<double>(c.refused_token), 4.0 + 4.0 * elapsed + 1.0);
  EXPECT_GT(c.refused_proof_rate, 0u);
}

TEST(HostileClients, SilentConnectionsReopenedDoNotKeepAClientOut) {
  LogCapture log;
  auto cfg = host_config(log);
  cfg.admission.summary_interval = 1s;
  auto host = net::NetHost::start(cfg);
  ASSERT_TRUE(host.ok()) << host.message();
  // 300 connections from ten addresses (30 each, under the per-address limit), more than
  // the free slots; each reopened as soon as the host drops it.
  test::SilentSwarm swarm((*host)->port(), 10, 30);
  ASSERT_TRUE(test::wait_until([&] { return swarm.connects() >= 200; }, 10s)) << dump((*host)->counters());
  const double first = seconds_to_connect(**host, "during-swarm", 5s);
  // Still under attack a few seconds on, after the first silent ones timed out and came back.
  std::this_thread::sleep_for(3s);
  const double second = seconds_to_connect(**host, "during-swarm-2", 5s);
  const auto c = (*host)->counters();
  std::printf("swarm: %llu connects, %llu drops; clients in %.3f s and %.3f s; %s\n",
              static_cast<unsigned long long>(swarm.connects()), static_cast<unsigned long long>(swarm.drops()), first,
              second, dump(c).c_str());
  EXPECT_GE(first, 0.0);
  EXPECT_GE(second, 0.0);
  EXPECT_GT(c.handshake_timeouts + c.handshake_evicted, 0u);
  EXPECT_GT(swarm.drops(), 0u) << "the silent connections were dropped (and reopened)";
}

// Issue 28, finding 1's third case: 8 clients from 8 addresses complete the handshake,
// fill every client slot, and vanish without a word (no disconnect reaches the host).
// The host's peer timeouts (peer_timeout_min 2 s, max 8 s) end their sessions and a client
// gets in: 3.0 s after they vanished, in every run here (a connect attempt every 0.3 s). With ENet's
// default timeouts (5 s minimum) the same test measured 7.1-8.1 s, and 28 s at issue time
// with a real session's megabytes outstanding, so the bound is the minimum plus 4 s.
TEST(HostileClients, ClientsThatVanishFreeTheirSlotsWithinThePeerTimeout) {
  LogCapture log;
  auto cfg = host_config(log);
  cfg.max_clients = 8;
  auto host = net::NetHost::start(cfg);
  ASSERT_TRUE(host.ok()) << host.message();
  enet_initialize();
  const ENetAddress to = test::loopback_port((*host)->port());
  auto hello = wire::encode(msg::Hello{msg::kProtocolVersion, 100, {}, "vanishing"});
  ASSERT_TRUE(hello.ok());
  std::vector<ENetHost*> vanishing;
  std::vector<bool> welcomed(8, false);
  for (int k = 0; k < 8; ++k) {
    ENetHost* h = test::host_on_loopback(2 + k, 1);
    ASSERT_NE(h, nullptr);
    ASSERT_NE(enet_host_connect(h, &to, msg::kChannelCount, 0), nullptr);
    vanishing.push_back(h);
  }
  // Each sends its Hello once connected and counts its Welcome; the host's policy
  // welcomes every Hello meanwhile.
  ASSERT_TRUE(test::wait_until([&] {
    welcome_all(**host);
    for (std::size_t k = 0; k < vanishing.size(); ++k) {
      ENetEvent ev;
      while (enet_host_service(vanishing[k], &ev, 0) > 0) {
        if (ev.type == ENET_EVENT_TYPE_CONNECT) {
          enet_peer_send(ev.peer, msg::channel_of(msg::MessageType::Hello),
                         enet_packet_create(hello->data(), hello->size(), ENET_PACKET_FLAG_RELIABLE));
        } else if (ev.type == ENET_EVENT_TYPE_RECEIVE) {
          auto m = wire::decode(std::span<const std::uint8_t>(ev.packet->data, ev.packet->dataLength));
          if (m && std::holds_alternative<msg::Welcome>(*m)) welcomed[k] = true;
          enet_packet_destroy(ev.packet);
        }
      }
    }
    return std::count(welcomed.begin(), welcomed.end(), true) == 8;
  }, 20s)) << dump((*host)->counters());
  EXPECT_LT(seconds_to_connect(**host, "while-full", 1s), 0.0) << "the eight hold every client slot";
  // They vanish: their ENet hosts are destroyed without a disconnect.
  for (ENetHost* h : vanishing) enet_host_destroy(h);
  enet_deinitialize();
  const auto t0 = Clock::now();
  double in = -1.0;
  while (in < 0.0 && Clock::now() - t0 < 20s) in = seconds_to_connect(**host, "after-vanish", 300ms);
  const double after = std::chrono::duration<double>(Clock::now() - t0).count();
  std::printf("8 vanished clients: a client got in %.1f s after they vanished; %s\n", after,
              dump((*host)->counters()).c_str());
  ASSERT_GE(in, 0.0) << "not in 20 s";
  EXPECT_LE(after, std::chrono::duration<double>(cfg.peer_timeout_min).count() + 4.0);
}

// Issue 28, finding 5's stalled half: sessions whose reliable channel waits on a message
// that never arrives. ENet holds everything behind the gap undelivered, so no garbage ever
// reaches the rejection count, and at issue time such sessions held the client slots for
// most of a minute. Here a relay loses one message of each for good (every retransmission
// too); the host drops them after stall_timeout (1 s here), counts them, and a client gets
// the slots back.
TEST(HostileClients, StalledChannelsDoNotHoldTheClientSlots) {
  LogCapture log;
  auto cfg = host_config(log);
  cfg.max_clients = 2;
  cfg.admission.stall_timeout = 1s;
  auto host = net::NetHost::start(cfg);
  ASSERT_TRUE(host.ok()) << host.message();
  const std::string marker = "this message is lost for good 0123456789";
  net::RelayPolicy policy;
  policy.drop_to_host = [marker](std::span<const std::uint8_t> d) {
    return std::search(d.begin(), d.end(), marker.begin(), marker.end()) != d.end();
  };
  auto relay = net::UdpRelay::start({"127.0.0.1", 0}, {"127.0.0.1", (*host)->port()}, policy);
  ASSERT_TRUE(relay.ok()) << relay.message();

  enet_initialize();
  ENetHost* h = enet_host_create(nullptr, 2, msg::kChannelCount, 0, 0);
  ASSERT_NE(h, nullptr);
  const ENetAddress to = test::loopback_port((*relay)->port());
  std::vector<ENetPeer*> peers;
  for (int k = 0; k < 2; ++k) peers.push_back(enet_host_connect(h, &to, msg::kChannelCount, 0));
  auto hello = wire::encode(msg::Hello{msg::kProtocolVersion, 100, {}, "staller"});
  ASSERT_TRUE(hello.ok());
  int welcomed = 0;
  auto service = [&] {
    ENetEvent ev;
    while (enet_host_service(h, &ev, 0) > 0) {
      if (ev.type == ENET_EVENT_TYPE_CONNECT) {
        enet_peer_send(ev.peer, msg::channel_of(msg::MessageType::Hello),
                       enet_packet_create(hello->data(), hello->size(), ENET_PACKET_FLAG_RELIABLE));
      } else if (ev.type == ENET_EVENT_TYPE_RECEIVE) {
        auto m = wire::decode(std::span<const std::uint8_t>(ev.packet->data, ev.packet->dataLength));
        welcomed += m && std::holds_alternative<msg::Welcome>(*m);
        enet_packet_destroy(ev.packet);
      }
    }
  };
  ASSERT_TRUE(test::wait_until([&] {
    welcome_all(**host);
    service();
    return welcomed == 2;
  }, 20s)) << dump((*host)->counters());
  EXPECT_LT(seconds_to_connect(**host, "while-full", 500ms), 0.0) << "the two hold every client slot";

  // Each sends the lost message, then garbage that waits behind it (one datagram each).
  const std::vector<std::uint8_t> lost(marker.begin(), marker.end());
  const std::vector<std::uint8_t> garbage(200, 0xEE);
  for (ENetPeer* p : peers) {
    enet_peer_send(p, 0, enet_packet_create(lost.data(), lost.size(), ENET_PACKET_FLAG_RELIABLE));
    enet_host_flush(h);
    enet_peer_send(p, 0, enet_packet_create(garbage.data(), garbage.size(), ENET_PACKET_FLAG_RELIABLE));
    enet_host_flush(h);
  }
  const auto t0 = Clock::now();
  // The stallers stay alive (their ENet answers pings and retransmits the lost message,
  // which the relay drops again) until the host drops them.
  const bool dropped = test::wait_until([&] {
    service();
    return (*host)->counters().stalled >= 2;
  }, 15s);
  const double after = std::chrono::duration<double>(Clock::now() - t0).count();
  const double in = seconds_to_connect(**host, "after-stall", 5s);
  const auto c = (*host)->counters();
  std::printf("2 stalled sessions: dropped %.1f s after stalling, a client in %.3f s; relay filtered %llu; %s\n", after,
              in, static_cast<unsigned long long>((*relay)->counters().filtered), dump(c).c_str());
  enet_host_destroy(h);
  enet_deinitialize();
  ASSERT_TRUE(dropped) << "not dropped in 15 s";
  EXPECT_EQ(c.stalled, 2u);
  EXPECT_GE(c.kicked, 2u);
  EXPECT_EQ(c.malformed, 0u) << "the garbage never reached the host's decoder";
  EXPECT_GE((*relay)->counters().filtered, 2u);
  EXPECT_GE(in, 0.0) << "a client gets a slot once the stalled sessions are gone";
}

}  // namespace
}  // namespace gauss
