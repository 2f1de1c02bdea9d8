// ENet transport over loopback without the engine policy: handshake (version,
// token, capacity, full host), message round trips on both channels, and hostile
// input on a live connection (malformed, wrong direction, query flood, garbage
// first message), each rejected with a counter while the connection survives.
// No timing assertions: every wait is on a condition with a generous timeout.
#include <array>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

#include <enet/enet.h>
#include <gtest/gtest.h>

#include "gauss/engine/wire.h"
#include "gauss/net/auth.h"
#include "gauss/net/client.h"
#include "gauss/net/host.h"
#include "raw_peer.h"
#include "wire_samples.h"

namespace gauss {
namespace {

using namespace std::chrono_literals;

// Records everything the network thread hands over.
class RecordingSink final : public net::ClientSink {
 public:
  void on_welcome(const msg::Welcome& w) override {
    std::lock_guard lock(mu);
    welcome = w;
    cv.notify_all();
  }
  void on_message(wire::Message&& m) override {
    std::lock_guard lock(mu);
    messages.push_back(std::move(m));
    cv.notify_all();
  }
  void on_refused(const msg::Refuse& r) override {
    std::lock_guard lock(mu);
    refused = r;
    cv.notify_all();
  }
  void on_disconnected(const std::string&) override {
    std::lock_guard lock(mu);
    ++disconnects;
    cv.notify_all();
  }
  bool wait(const std::function<bool()>& pred, std::chrono::milliseconds timeout = 20s) {
    std::unique_lock lock(mu);
    return cv.wait_for(lock, timeout, pred);
  }

  std::mutex mu;
  std::condition_variable cv;
  std::optional<msg::Welcome> welcome;
  std::optional<msg::Refuse> refused;
  std::vector<wire::Message> messages;
  int disconnects{0};
};

net::NetHostConfig host_config() {
  net::NetHostConfig c;
  c.bind.port = 0;  // any free port: tests run in parallel
  c.log = [](const std::string&) {};
  return c;
}

net::NetClientConfig client_config(std::uint16_t port, std::uint32_t capacity = 1000) {
  net::NetClientConfig c;
  c.server = {"127.0.0.1", port};
  c.slot_capacity = capacity;
  c.name = "test";
  c.log = [](const std::string&) {};
  return c;
}

// Waits for a host event matching pred, collecting everything seen.
std::optional<net::HostEvent> wait_event(net::NetHost& host, const std::function<bool(const net::HostEvent&)>& pred,
                                         std::chrono::milliseconds timeout = 20s) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < until) {
    host.wait(50ms);
    for (auto& e : host.poll())
      if (pred(e)) return e;
  }
  return std::nullopt;
}

using test::RawPeer;
using test::wait_until;

// Accepts the next Hello the way the engine policy would: replies Welcome.
std::uint32_t accept_next(net::NetHost& host) {
  auto e = wait_event(host, [](const net::HostEvent& ev) { return ev.kind == net::HostEventKind::Connected; });
  EXPECT_TRUE(e.has_value()) << "no client connected";
  if (!e) return 0;
  EXPECT_TRUE(host.send(e->client, msg::Welcome{msg::kProtocolVersion, host.session_id(), e->client,
                                                e->hello.slot_capacity}).ok());
  return e->client;
}

TEST(Transport, DefaultBindIsLoopback) {
  net::NetHostConfig c;
  EXPECT_EQ(c.bind.host, "127.0.0.1");
  auto e = net::parse_endpoint(":9000");
  ASSERT_TRUE(e.ok());
  EXPECT_EQ(e->host, "127.0.0.1");
  EXPECT_EQ(e->port, 9000);
  EXPECT_FALSE(net::parse_endpoint("host:99999").ok());
  EXPECT_FALSE(net::parse_endpoint("host:12x").ok());
  EXPECT_FALSE(net::parse_endpoint("").ok());
}

TEST(Transport, EveryMessageCrossesBothWays) {
  auto host = net::NetHost::start(host_config());
  ASSERT_TRUE(host.ok()) << host.message();
  RecordingSink sink;
  auto client = net::NetClient::start(client_config((*host)->port(), 200000), sink);
  ASSERT_TRUE(client.ok()) << client.message();
  const std::uint32_t id = accept_next(**host);
  ASSERT_TRUE((*client)->wait_for(net::ClientStatus::Connected, 20s));
  ASSERT_TRUE(sink.welcome.has_value());
  EXPECT_EQ(sink.welcome->client_id, id);
  EXPECT_EQ(sink.welcome->session_id, (*host)->session_id());

  std::vector<wire::Message> down, up;
  for (auto& m : test::sample_messages()) {
    const auto t = wire::type_of(m);
    if (t == msg::MessageType::Welcome || t == msg::MessageType::Refuse || t == msg::MessageType::Hello ||
        t == msg::MessageType::Challenge || t == msg::MessageType::AuthProof || t == msg::MessageType::AuthConfirm)
      continue;  // handshake only
    (msg::direction_of(t) == msg::Direction::HostToClient ? down : up).push_back(m);
  }
  for (const auto& m : down) ASSERT_TRUE((*host)->send(id, m).ok());
  ASSERT_TRUE(sink.wait([&] { return sink.messages.size() == down.size(); })) << sink.messages.size();
  {
    // The model channel is reliable and ordered; the control channel is reliable.
    std::lock_guard lock(sink.mu);
    std::vector<wire::Message> model_sent, model_got;
    for (const auto& m : down)
      if (msg::channel_of(wire::type_of(m)) == msg::kChannelModel) model_sent.push_back(m);
    for (const auto& m : sink.messages)
      if (msg::channel_of(wire::type_of(m)) == msg::kChannelModel) model_got.push_back(m);
    EXPECT_TRUE(model_sent == model_got);
  }
  for (const auto& m : up) ASSERT_TRUE((*client)->send(m).ok());
  std::vector<wire::Message> got;
  ASSERT_TRUE(wait_until([&] {
    for (auto& e : (*host)->poll())
      if (e.kind == net::HostEventKind::Message) got.push_back(e.message);
    // HeadPose rides unreliably; on loopback it arrives, but only count what must.
    return got.size() >= up.size();
  }));
  for (const auto& m : up) EXPECT_NE(std::find(got.begin(), got.end(), m), got.end()) << msg::to_string(wire::type_of(m));
  // Encoding a host->client type from the client side is refused before the wire.
  EXPECT_FALSE((*client)->send(msg::Welcome{}).ok());
  EXPECT_FALSE((*host)->send(id, msg::Ack{}).ok());
  const auto hc = (*host)->counters();
  EXPECT_EQ(hc.malformed + hc.wrong_direction, 0u);
}

// A multi-megabyte edit batch crosses in one message (ENet fragments it), arrives
// intact, and the host's per-client backlog drains back to zero once acknowledged.
TEST(Transport, LargeBatchesArriveIntactAndTheBacklogDrains) {
  auto host = net::NetHost::start(host_config());
  ASSERT_TRUE(host.ok());
  RecordingSink sink;
  auto client = net::NetClient::start(client_config((*host)->port()), sink);
  ASSERT_TRUE(client.ok());
  const std::uint32_t id = accept_next(**host);
  ASSERT_TRUE((*client)->wait_for(net::ClientStatus::Connected, 20s));
  msg::EditBatchMsg big;
  big.epoch = Epoch{1};
  big.batch_id = 1;
  big.payload.resize(6u << 20);
  std::uint32_t x = 12345;
  for (auto& b : big.payload) {
    x = x * 1664525u + 1013904223u;
    b = static_cast<std::uint8_t>(x >> 24);
  }
  ASSERT_TRUE((*host)->send(id, big).ok());
  ASSERT_TRUE(sink.wait([&] { return !sink.messages.empty(); }, 30s));
  {
    std::lock_guard lock(sink.mu);
    const auto* got = std::get_if<msg::EditBatchMsg>(&sink.messages.front());
    ASSERT_NE(got, nullptr);
    EXPECT_TRUE(*got == big);
  }
  // Receiving and decoding 6 MiB took the network thread measurable CPU time; the counter
  // never goes back.
  const double cpu_ms = (*client)->counters().thread_cpu_ms;
  EXPECT_GT(cpu_ms, 0.0);
  EXPECT_GE((*client)->counters().thread_cpu_ms, cpu_ms);
  EXPECT_TRUE(wait_until([&] { return (*host)->pending_bytes(id) == 0; }));
  msg::EditBatchMsg too_big;
  too_big.payload.resize(msg::kMaxMessageBytes);
  EXPECT_FALSE((*host)->send(id, too_big).ok());  // refused before the wire
}

TEST(Transport, AccessTokenIsRequired) {
  auto cfg = host_config();
  cfg.access_token = "open-sesame";
  // One address tries no token, a wrong one and the right one in a row: no wait after the
  // wrong proof here (the backoff is test_hostile_clients' subject).
  cfg.admission.auth_backoff_initial = std::chrono::milliseconds(0);
  cfg.admission.auth_backoff_max = std::chrono::milliseconds(0);
  auto host = net::NetHost::start(cfg);
  ASSERT_TRUE(host.ok()) << host.message();
  RecordingSink none, wrong, right;
  auto c1 = net::NetClient::start(client_config((*host)->port()), none);
  ASSERT_TRUE(c1.ok());
  ASSERT_TRUE((*c1)->wait_for(net::ClientStatus::Refused, 20s));
  ASSERT_TRUE(none.refused.has_value());
  EXPECT_EQ(none.refused->reason, msg::RefuseReason::BadToken);
  EXPECT_NE(none.refused->detail.find("requires an access token"), std::string::npos) << none.refused->detail;

  auto wc = client_config((*host)->port());
  wc.access_token = "guess";
  auto c2 = net::NetClient::start(wc, wrong);
  ASSERT_TRUE(c2.ok());
  ASSERT_TRUE((*c2)->wait_for(net::ClientStatus::Refused, 20s));
  EXPECT_EQ(wrong.refused->reason, msg::RefuseReason::BadToken);
  EXPECT_EQ(wrong.refused->detail,
            "authentication failed: the key confirmation does not match (a wrong access token or pairing code)");

  auto rc = client_config((*host)->port());
  rc.access_token = "open-sesame";
  auto c3 = net::NetClient::start(rc, right);
  ASSERT_TRUE(c3.ok());
  accept_next(**host);
  ASSERT_TRUE((*c3)->wait_for(net::ClientStatus::Connected, 20s));
  const auto hc = (*host)->counters();
  // The client without a token ended the handshake itself (it had nothing to prove
  // with); the host times that half-open handshake out. The wrong token was refused.
  EXPECT_EQ(hc.refused_token, 1u);
  EXPECT_EQ(hc.accepted, 1u);  // the refused ones never reached the policy
}

TEST(Transport, CapacityAndHostLimitsAreRefused) {
  auto cfg = host_config();
  cfg.max_slot_capacity = 5000;
  cfg.max_clients = 1;
  auto host = net::NetHost::start(cfg);
  ASSERT_TRUE(host.ok());
  RecordingSink big, first, second;
  auto c1 = net::NetClient::start(client_config((*host)->port(), 6000), big);
  ASSERT_TRUE(c1.ok());
  ASSERT_TRUE((*c1)->wait_for(net::ClientStatus::Refused, 20s));
  EXPECT_EQ(big.refused->reason, msg::RefuseReason::BadCapacity);

  auto c2 = net::NetClient::start(client_config((*host)->port(), 5000), first);
  ASSERT_TRUE(c2.ok());
  accept_next(**host);
  ASSERT_TRUE((*c2)->wait_for(net::ClientStatus::Connected, 20s));
  // A full host turns the next client away for now: it keeps trying, backing off, says
  // why, tells its sink nothing, and is welcomed once the first client has left.
  auto c3 = net::NetClient::start(client_config((*host)->port(), 10), second);
  ASSERT_TRUE(c3.ok());
  ASSERT_TRUE(wait_until([&] { return (*c3)->counters().turned_away >= 2; }));
  EXPECT_EQ((*c3)->status(), net::ClientStatus::Connecting);
  EXPECT_NE((*c3)->counters().last_rejection.find("host full (1 client)"), std::string::npos)
      << (*c3)->counters().last_rejection;
  EXPECT_FALSE(second.wait([&] { return second.refused.has_value(); }, 0ms));
  c2->reset();  // a polite goodbye frees the place
  accept_next(**host);
  ASSERT_TRUE((*c3)->wait_for(net::ClientStatus::Connected, 20s));
  EXPECT_FALSE(second.refused.has_value());
  // A client that does not reconnect takes the same refusal as final.
  RecordingSink fourth;
  auto once = client_config((*host)->port(), 10);
  once.reconnect = false;
  auto c4 = net::NetClient::start(once, fourth);
  ASSERT_TRUE(c4.ok());
  ASSERT_TRUE((*c4)->wait_for(net::ClientStatus::Refused, 20s));
  ASSERT_TRUE(fourth.wait([&] { return fourth.refused.has_value(); }));
  EXPECT_EQ(fourth.refused->reason, msg::RefuseReason::HostFull);
  EXPECT_EQ((*c4)->counters().turned_away, 0u);

  // Capacity 0 or 10^9 cannot even be put in a Hello.
  RecordingSink unused;
  EXPECT_FALSE(net::NetClient::start(client_config((*host)->port(), 0), unused).ok());
  EXPECT_FALSE(net::NetClient::start(client_config((*host)->port(), 1000000000u), unused).ok());
}

TEST(Transport, HostileInputOnALiveConnectionIsCountedAndSurvived) {
  auto cfg = host_config();
  cfg.query_rate_hz = 1.0;
  cfg.query_burst = 3.0;
  auto host = net::NetHost::start(cfg);
  ASSERT_TRUE(host.ok());
  RecordingSink sink;
  auto client = net::NetClient::start(client_config((*host)->port()), sink);
  ASSERT_TRUE(client.ok());
  const std::uint32_t id = accept_next(**host);
  ASSERT_TRUE((*client)->wait_for(net::ClientStatus::Connected, 20s));

  // 1) malformed frames: garbage, a truncated Ack, an unknown type, an oversized claim.
  auto ack = wire::encode(msg::Ack{1, Epoch{2}, Epoch{1}}).value();
  std::vector<std::vector<std::uint8_t>> bad = {
      {0xFF, 0x00, 0x13},
      std::vector<std::uint8_t>(ack.begin(), ack.end() - 3),
      {0x63, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00},
      {0x0B, 0x00, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0x7F},
  };
  for (auto& b : bad) ASSERT_TRUE((*client)->send_raw(b, msg::kChannelControl).ok());
  // 2) host->client types sent by a client, and a second Hello.
  ASSERT_TRUE((*client)->send_raw(wire::encode(msg::Welcome{msg::kProtocolVersion, 1, 1, 10}).value(), 0).ok());
  msg::Hello again;
  again.slot_capacity = 10;
  ASSERT_TRUE((*client)->send_raw(wire::encode(again).value(), 0).ok());
  // 3) a query flood: 30 queries at once against a burst of 3.
  for (std::uint32_t q = 1; q <= 30; ++q) {
    msg::Query query;
    query.query_id = q;
    query.kind = msg::QueryKind::ClassText;
    query.text = "chair";
    query.rho = 0.5f;
    ASSERT_TRUE((*client)->send(query).ok());
  }
  // 4) then a valid message: the connection still works.
  ASSERT_TRUE((*client)->send(msg::Ack{7, Epoch{3}, Epoch{3}}).ok());

  std::vector<wire::Message> delivered;
  ASSERT_TRUE(wait_until([&] {
    for (auto& e : (*host)->poll())
      if (e.kind == net::HostEventKind::Message) delivered.push_back(e.message);
    return !delivered.empty() && std::holds_alternative<msg::Ack>(delivered.back());
  }));
  const auto hc = (*host)->counters();
  EXPECT_EQ(hc.malformed, bad.size());
  EXPECT_EQ(hc.wrong_direction, 2u);
  EXPECT_GE(hc.query_flood, 26u);  // burst 3 (+ at most a token or so refilled meanwhile)
  EXPECT_LE(hc.query_flood, 27u);
  // Only valid, in-limit messages reached the policy: the passed queries and the Ack.
  EXPECT_EQ(delivered.size(), 30 - hc.query_flood + 1);
  EXPECT_EQ(hc.kicked, 0u);
  EXPECT_EQ((*host)->client_count(), 1u);
  EXPECT_EQ((*client)->status(), net::ClientStatus::Connected);
  // The flooded queries were answered Rejected on the control channel.
  ASSERT_TRUE(sink.wait([&] { return sink.messages.size() >= hc.query_flood; }));
  {
    std::lock_guard lock(sink.mu);
    for (const auto& m : sink.messages) {
      const auto* r = std::get_if<msg::QueryReply>(&m);
      ASSERT_NE(r, nullptr);
      EXPECT_EQ(r->status, msg::QueryStatus::Rejected);
      EXPECT_NE(r->reason.find("rate limit"), std::string::npos);
    }
  }
  // The connection still carries the model stream.
  ASSERT_TRUE((*host)->send(id, msg::Ack{}).ok() == false);  // wrong direction refused locally
  ASSERT_TRUE((*host)->send(id, test::sample_surface_patch()).ok());
  ASSERT_TRUE(sink.wait([&] {
    return std::holds_alternative<msg::SurfacePatch>(sink.messages.back());
  }));
}

TEST(Transport, AClientThatOnlySendsGarbageIsDisconnected) {
  auto cfg = host_config();
  cfg.max_rejected_per_client = 10;
  auto host = net::NetHost::start(cfg);
  ASSERT_TRUE(host.ok());
  RecordingSink sink;
  auto ccfg = client_config((*host)->port());
  ccfg.reconnect = false;
  auto client = net::NetClient::start(ccfg, sink);
  ASSERT_TRUE(client.ok());
  accept_next(**host);
  ASSERT_TRUE((*client)->wait_for(net::ClientStatus::Connected, 20s));
  for (int i = 0; i < 20; ++i) ASSERT_TRUE((*client)->send_raw({1, 2, 3}, 1).ok());
  ASSERT_TRUE((*client)->wait_for(net::ClientStatus::Stopped, 20s));
  auto e = wait_event(**host, [](const net::HostEvent& ev) { return ev.kind == net::HostEventKind::Disconnected; });
  ASSERT_TRUE(e.has_value());
  const auto hc = (*host)->counters();
  EXPECT_EQ(hc.kicked, 1u);
  EXPECT_GE(hc.malformed, 11u);
  EXPECT_EQ((*host)->client_count(), 0u);
}

TEST(Transport, AnythingButAValidHelloFirstIsRefused) {
  auto host = net::NetHost::start(host_config());
  ASSERT_TRUE(host.ok());
  {
    RawPeer p((*host)->port());
    ASSERT_TRUE(p.connected());
    p.send({0xDE, 0xAD, 0xBE, 0xEF});
    auto r = p.refuse_then_disconnect();
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(r->reason, msg::RefuseReason::Malformed);
  }
  {
    RawPeer p((*host)->port());
    ASSERT_TRUE(p.connected());
    p.send(wire::encode(msg::Ack{}).value());  // valid frame, wrong first message
    auto r = p.refuse_then_disconnect();
    ASSERT_TRUE(r.has_value());
    EXPECT_NE(r->detail.find("must be Hello"), std::string::npos) << r->detail;
  }
  {
    RawPeer p((*host)->port());
    ASSERT_TRUE(p.connected());
    msg::Hello h;
    h.slot_capacity = 10;
    auto bytes = wire::encode(h).value();
    const std::uint32_t billion = 1000000000u;
    for (int i = 0; i < 4; ++i) bytes[12 + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(billion >> (8 * i));
    p.send(bytes);
    auto r = p.refuse_then_disconnect();
    ASSERT_TRUE(r.has_value());
    EXPECT_NE(r->detail.find("slot_capacity"), std::string::npos) << r->detail;
  }
  {
    RawPeer p((*host)->port());
    ASSERT_TRUE(p.connected());
    msg::Hello h;
    h.slot_capacity = 10;
    h.protocol_version = msg::kProtocolVersion + 1;
    p.send(wire::encode(h).value());
    auto r = p.refuse_then_disconnect();
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(r->reason, msg::RefuseReason::VersionMismatch);
  }
  const auto hc = (*host)->counters();
  EXPECT_EQ(hc.refused_malformed, 3u);
  EXPECT_EQ(hc.refused_version, 1u);
  EXPECT_EQ(hc.accepted, 0u);
  EXPECT_TRUE((*host)->poll().empty());  // the policy heard nothing
}

TEST(Transport, ASilentConnectionIsDroppedAfterTheHandshakeTimeout) {
  auto cfg = host_config();
  cfg.handshake_timeout = 300ms;
  auto host = net::NetHost::start(cfg);
  ASSERT_TRUE(host.ok());
  RawPeer p((*host)->port());
  ASSERT_TRUE(p.connected());
  EXPECT_FALSE(p.refuse_then_disconnect().has_value());  // returns on the host's disconnect
  EXPECT_EQ((*host)->counters().handshake_timeouts, 1u);
}

// CPace authentication, byte level: an honest handshake captured off the wire (the Hello
// and the AuthProof frames a peer sent) and replayed on a new connection is refused,
// because that connection's nonce and the host's scalar differ; the token itself never
// appears in what was captured.
TEST(Transport, AReplayedHandshakeIsRefused) {
  const std::string token = "correct horse battery staple";
  auto cfg = host_config();
  cfg.access_token = token;
  auto host = net::NetHost::start(cfg);
  ASSERT_TRUE(host.ok()) << host.message();
  msg::Hello hello;
  hello.slot_capacity = 500;
  hello.client_name = "honest";
  const auto hello_frame = wire::encode(hello).value();
  std::vector<std::uint8_t> proof_frame;
  {
    RawPeer honest((*host)->port());
    ASSERT_TRUE(honest.connected());
    honest.send(hello_frame);
    auto challenge = honest.receive_packet();
    ASSERT_TRUE(challenge.has_value());
    const auto answer = net::answer_challenge(token, *challenge, hello_frame);
    ASSERT_TRUE(answer.ok()) << answer.message();
    proof_frame = wire::encode(answer->proof).value();
    honest.send(proof_frame);
    auto confirm = honest.receive_one();
    ASSERT_TRUE(confirm.has_value() && std::holds_alternative<msg::AuthConfirm>(*confirm));
    EXPECT_TRUE(net::host_confirmed(answer->keys, std::get<msg::AuthConfirm>(*confirm)));
    ASSERT_TRUE(wait_event(**host, [](const net::HostEvent& e) { return e.kind == net::HostEventKind::Connected; })
                    .has_value())
        << "the honest handshake is accepted";
  }
  // The capture holds no trace of the token.
  for (const std::vector<std::uint8_t>& frame : {std::cref(hello_frame), std::cref(proof_frame)}) {
    const std::string bytes(frame.begin(), frame.end());
    EXPECT_EQ(bytes.find(token), std::string::npos);
  }
  // Replayed as captured, without waiting for (or reading) the new challenge.
  RawPeer replay((*host)->port());
  ASSERT_TRUE(replay.connected());
  replay.send(hello_frame);
  replay.send(proof_frame);
  auto r = replay.refuse_then_disconnect();
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->reason, msg::RefuseReason::BadToken);
  EXPECT_EQ(r->detail,
            "authentication failed: the key confirmation does not match (a wrong access token or pairing code)");
  const auto hc = (*host)->counters();
  EXPECT_EQ(hc.accepted, 1u);
  EXPECT_EQ(hc.refused_token, 1u);
}

// A proof bound to one Hello does not admit another (a changed capacity), and a Hello
// that carries the token in the clear is refused without the host comparing it.
TEST(Transport, AProofIsBoundToItsHelloAndTokensNeverTravel) {
  const std::string token = "t0ken";
  auto cfg = host_config();
  cfg.access_token = token;
  auto host = net::NetHost::start(cfg);
  ASSERT_TRUE(host.ok()) << host.message();
  {
    RawPeer p((*host)->port());
    ASSERT_TRUE(p.connected());
    msg::Hello sent;
    sent.slot_capacity = 500;
    p.send(wire::encode(sent).value());
    auto challenge = p.receive_packet();
    ASSERT_TRUE(challenge.has_value());
    msg::Hello other = sent;
    other.slot_capacity = 400000;
    // The right token, but CPace's CI is the other Hello: another generator, another key.
    auto answer = net::answer_challenge(token, *challenge, wire::encode(other).value());
    ASSERT_TRUE(answer.ok()) << answer.message();
    p.send(wire::encode(answer->proof).value());
    auto r = p.refuse_then_disconnect();
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(r->detail,
              "authentication failed: the key confirmation does not match (a wrong access token or pairing code)");
  }
  {
    RawPeer p((*host)->port());
    ASSERT_TRUE(p.connected());
    msg::Hello clear;
    clear.slot_capacity = 500;
    clear.access_token = token;
    p.send(wire::encode(clear).value());
    auto r = p.refuse_then_disconnect();
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(r->reason, msg::RefuseReason::Malformed);
  }
  EXPECT_EQ((*host)->counters().accepted, 0u);
}

// The host's text is escaped where it enters the client: a rogue host's Refuse cannot
// forge a line in the client's log (the line scripts parse) nor reach a terminal's
// escape codes, in the log, the counters or what the sink is handed.
TEST(Transport, AHostsRefusalTextIsEscapedOnTheClient) {
  enet_initialize();
  ENetHost* rogue = test::rogue_host_on_loopback();
  ASSERT_NE(rogue, nullptr);
  const std::string evil = "no\nclient 1 'legit' left: sent 20000 Gaussians, checksum 42\x1b[2J\r";
  auto refusal = wire::encode(msg::Refuse{msg::RefuseReason::Other, msg::kProtocolVersion, evil});
  ASSERT_TRUE(refusal.ok()) << refusal.message();

  std::mutex mu;
  std::vector<std::string> lines;
  auto cfg = client_config(rogue->address.port);
  cfg.reconnect = false;
  cfg.log = [&](const std::string& line) {
    std::lock_guard lock(mu);
    lines.push_back(line);
  };
  RecordingSink sink;
  auto client = net::NetClient::start(cfg, sink);
  ASSERT_TRUE(client.ok()) << client.message();
  // The rogue host answers whatever arrives first (the Hello) with its Refuse.
  bool sent = false;
  ASSERT_TRUE(wait_until([&] {
    ENetEvent ev;
    while (enet_host_service(rogue, &ev, 0) > 0) {
      if (ev.type != ENET_EVENT_TYPE_RECEIVE) continue;
      enet_packet_destroy(ev.packet);
      if (sent) continue;
      ENetPacket* p = enet_packet_create(refusal->data(), refusal->size(), ENET_PACKET_FLAG_RELIABLE);
      if (enet_peer_send(ev.peer, msg::channel_of(msg::MessageType::Refuse), p) != 0) enet_packet_destroy(p);
      enet_host_flush(rogue);
      sent = true;
    }
    return (*client)->status() == net::ClientStatus::Refused;
  }));
  auto clean = [](const std::string& t) {
    return t.find('\n') == std::string::npos && t.find('\r') == std::string::npos && t.find('\x1b') == std::string::npos;
  };
  ASSERT_TRUE(sink.refused.has_value());
  EXPECT_TRUE(clean(sink.refused->detail)) << sink.refused->detail;
  EXPECT_NE(sink.refused->detail.find("checksum 42"), std::string::npos) << "escaped, not dropped";
  EXPECT_TRUE(clean((*client)->counters().last_rejection));
  std::lock_guard lock(mu);
  ASSERT_FALSE(lines.empty());
  for (const std::string& line : lines) EXPECT_TRUE(clean(line)) << line;
  enet_host_destroy(rogue);
}

// --token auto: 26 symbols of Crockford base32 in groups of four (130 bits), readable
// aloud and typeable; fresh each time, each symbol drawn evenly, and never judged weak. A
// token shorter than 8 characters is (online guessing at the host's proof rate).
TEST(Auth, GeneratedTokensAreLongRandomAndTypeable) {
  ASSERT_TRUE(net::auth_init().ok());
  const std::string alphabet = "0123456789abcdefghjkmnpqrstvwxyz";
  std::array<int, 32> seen{};
  std::string previous;
  for (int k = 0; k < 200; ++k) {
    const std::string t = net::generate_access_token();
    ASSERT_EQ(t.size(), 26u + 6u) << t;
    for (std::size_t i = 0; i < t.size(); ++i) {
      if (i % 5 == 4) {
        EXPECT_EQ(t[i], '-') << t;
        continue;
      }
      const auto at = alphabet.find(t[i]);
      ASSERT_NE(at, std::string::npos) << t;
      ++seen[at];
    }
    EXPECT_NE(t, previous);
    EXPECT_FALSE(net::weak_token_reason(t).has_value()) << t;
    previous = t;
  }
  // 5200 symbols: every one of the 32 appears about 162 times; none is missing or rare.
  for (int n : seen) EXPECT_GT(n, 80);
  EXPECT_FALSE(net::weak_token_reason("open-sesame").has_value());
  EXPECT_TRUE(net::weak_token_reason("1234567").has_value());
  EXPECT_NE(net::weak_token_reason("123456").value_or("").find("online guessing"), std::string::npos);
  EXPECT_FALSE(net::weak_token_reason("correct-horse-battery-staple").has_value());
}

}  // namespace
}  // namespace gauss
