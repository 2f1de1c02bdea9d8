// Sealed streams (NetHostConfig::encrypt_stream, stream_cipher.h): the cipher's contract
// (round trip, per-connection and per-direction keys, replays and alterations refused,
// reordering within the window accepted, a forgery spends no counter), and on a live
// loopback connection: everything after the proof travels sealed both ways, nothing the
// host sends reads as a frame on the wire, and a replayed, altered or plain packet from
// the client is rejected and counted without reaching the policy.
#include <chrono>
#include <string>
#include <thread>

#include <enet/enet.h>
#include <gtest/gtest.h>

#include "gauss/engine/wire.h"
#include "gauss/net/auth.h"
#include "gauss/net/host.h"
#include "gauss/net/stream_cipher.h"
#include "raw_peer.h"

namespace gauss {
namespace {

using namespace std::chrono_literals;

std::vector<std::uint8_t> bytes_of(const std::string& s) { return {s.begin(), s.end()}; }

struct Keys {
  msg::Challenge challenge;
  std::vector<std::uint8_t> hello{1, 2, 3, 4, 5};
  Keys() {
    EXPECT_TRUE(net::auth_init().ok());
    challenge = net::make_challenge();
    challenge.flags = msg::kChallengeEncrypt;
  }
};

TEST(StreamCipher, RoundTripsAndTheWireCarriesNoPlaintext) {
  Keys k;
  net::StreamCipher seal("token", k.challenge, k.hello, net::StreamDirection::HostToClient);
  net::StreamCipher open("token", k.challenge, k.hello, net::StreamDirection::HostToClient);
  const auto frame = bytes_of("the chair is in the corner");
  const auto packet = seal.seal(frame);
  EXPECT_EQ(packet.size(), frame.size() + net::kSealedHeaderBytes + net::kSealedTagBytes);
  EXPECT_TRUE(net::looks_sealed(packet));
  EXPECT_EQ(std::string(packet.begin(), packet.end()).find("chair"), std::string::npos);
  auto back = open.open(packet);
  ASSERT_TRUE(back.ok()) << back.message();
  EXPECT_EQ(*back, frame);
  // An empty frame too (the tag alone).
  auto empty = open.open(seal.seal({}));
  ASSERT_TRUE(empty.ok()) << empty.message();
  EXPECT_TRUE(empty->empty());
}

TEST(StreamCipher, KeysDifferPerTokenConnectionAndDirection) {
  Keys k, other;
  net::StreamCipher seal("token", k.challenge, k.hello, net::StreamDirection::HostToClient);
  const auto packet = seal.seal(bytes_of("frame"));
  net::StreamCipher wrong_token("tokem", k.challenge, k.hello, net::StreamDirection::HostToClient);
  net::StreamCipher wrong_nonce("token", other.challenge, k.hello, net::StreamDirection::HostToClient);
  net::StreamCipher wrong_hello("token", k.challenge, bytes_of("another hello"), net::StreamDirection::HostToClient);
  net::StreamCipher wrong_way("token", k.challenge, k.hello, net::StreamDirection::ClientToHost);
  EXPECT_FALSE(wrong_token.open(packet).ok());
  EXPECT_FALSE(wrong_nonce.open(packet).ok());
  EXPECT_FALSE(wrong_hello.open(packet).ok());
  EXPECT_FALSE(wrong_way.open(packet).ok()) << "a packet cannot be reflected back to its sender";
}

TEST(StreamCipher, ReplaysAndAlterationsAreRefusedReorderingIsNot) {
  Keys k;
  net::StreamCipher seal("t", k.challenge, k.hello, net::StreamDirection::ClientToHost);
  net::StreamCipher open("t", k.challenge, k.hello, net::StreamDirection::ClientToHost);
  std::vector<std::vector<std::uint8_t>> packets;
  for (int i = 0; i < 6; ++i) packets.push_back(seal.seal(bytes_of("frame " + std::to_string(i))));
  // Out of order within the window: accepted, each once.
  for (int i : {1, 0, 3, 2}) EXPECT_TRUE(open.open(packets[static_cast<std::size_t>(i)]).ok()) << i;
  EXPECT_FALSE(open.open(packets[0]).ok()) << "replayed";
  EXPECT_FALSE(open.open(packets[3]).ok()) << "replayed";
  // Any altered byte (header, ciphertext, tag) fails, and spends no counter: the
  // genuine packet still opens afterwards.
  for (std::size_t at : {std::size_t{5}, net::kSealedHeaderBytes + 1, packets[4].size() - 1}) {
    auto bad = packets[4];
    bad[at] ^= 0x01;
    EXPECT_FALSE(open.open(bad).ok()) << "byte " << at;
  }
  EXPECT_TRUE(open.open(packets[4]).ok());
  // A truncated packet and a plain frame are not sealed packets.
  EXPECT_FALSE(open.open(std::span(packets[5]).first(net::kSealedHeaderBytes + 3)).ok());
  EXPECT_FALSE(open.open(wire::encode(msg::Ack{}).value()).ok());
  // Older than the window: refused even though never seen.
  for (std::size_t i = 0; i < net::kReplayWindow + 1; ++i) ASSERT_TRUE(open.open(seal.seal(bytes_of("x"))).ok());
  EXPECT_FALSE(open.open(packets[5]).ok()) << "more than the window behind the newest";
}

// A raw ENet client speaking the sealed protocol by hand, so the test can replay, alter
// and send plain packets after the handshake.
class SealedPeer {
 public:
  SealedPeer(std::uint16_t port, const std::string& token) : raw_(port), token_(token) {}

  // Hello, Challenge (must ask for a sealed stream), proof; then the keys.
  bool handshake() {
    if (!raw_.connected()) return false;
    msg::Hello hello;
    hello.slot_capacity = 100;
    hello.client_name = "sealed";
    const auto hello_frame = wire::encode(hello).value();
    raw_.send(hello_frame);
    auto m = raw_.receive_one();
    if (!m || !std::holds_alternative<msg::Challenge>(*m)) return false;
    const auto& challenge = std::get<msg::Challenge>(*m);
    if (!(challenge.flags & msg::kChallengeEncrypt)) return false;
    raw_.send(wire::encode(net::auth_proof(token_, challenge, hello_frame)).value());
    sealer_ = std::make_unique<net::StreamCipher>(token_, challenge, hello_frame, net::StreamDirection::ClientToHost);
    opener_ = std::make_unique<net::StreamCipher>(token_, challenge, hello_frame, net::StreamDirection::HostToClient);
    return true;
  }
  void send(const std::vector<std::uint8_t>& bytes) { raw_.send(bytes); }
  std::vector<std::uint8_t> seal(const wire::Message& m) { return sealer_->seal(wire::encode(m).value()); }
  std::optional<std::vector<std::uint8_t>> receive_packet() { return raw_.receive_packet(); }
  Expected<std::vector<std::uint8_t>> open(const std::vector<std::uint8_t>& packet) { return opener_->open(packet); }
  void service(std::chrono::milliseconds d) { raw_.service(d); }

 private:
  test::RawPeer raw_;
  std::string token_;
  std::unique_ptr<net::StreamCipher> sealer_, opener_;
};

std::vector<net::HostEvent> events_until(net::NetHost& host, const std::function<bool(const net::HostEvent&)>& pred,
                                         std::chrono::milliseconds timeout = 20s) {
  std::vector<net::HostEvent> seen;
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < until) {
    host.wait(20ms);
    for (auto& e : host.poll()) {
      seen.push_back(e);
      if (pred(e)) return seen;
    }
  }
  return seen;
}

TEST(SealedStream, ALiveConnectionIsSealedBothWaysAndRefusesReplays) {
  const std::string token = "private scene";
  net::NetHostConfig cfg;
  cfg.bind.port = 0;
  cfg.access_token = token;
  cfg.encrypt_stream = true;
  cfg.log = [](const std::string&) {};
  auto host = net::NetHost::start(cfg);
  ASSERT_TRUE(host.ok()) << host.message();
  SealedPeer peer((*host)->port(), token);
  ASSERT_TRUE(peer.handshake());
  auto connected = events_until(**host, [](const net::HostEvent& e) { return e.kind == net::HostEventKind::Connected; });
  ASSERT_FALSE(connected.empty());
  ASSERT_EQ(connected.back().kind, net::HostEventKind::Connected);
  const std::uint32_t id = connected.back().client;

  // Host -> client: the Welcome and a reply with a telling label arrive sealed.
  ASSERT_TRUE((*host)->send(id, msg::Welcome{msg::kProtocolVersion, (*host)->session_id(), id, 100}).ok());
  msg::ObjectTableUpdate table;
  msg::ObjectInfo secret;
  secret.id = ObjectId{4};
  secret.label = "secret-prototype";
  table.upserts.push_back(secret);
  ASSERT_TRUE((*host)->send(id, table).ok());
  for (int k = 0; k < 2; ++k) {
    auto packet = peer.receive_packet();
    ASSERT_TRUE(packet.has_value());
    EXPECT_TRUE(net::looks_sealed(*packet));
    EXPECT_FALSE(wire::decode(*packet).ok()) << "a sealed packet is no frame";
    EXPECT_EQ(std::string(packet->begin(), packet->end()).find("secret-prototype"), std::string::npos);
    auto frame = peer.open(*packet);
    ASSERT_TRUE(frame.ok()) << frame.message();
    auto m = wire::decode(*frame);
    ASSERT_TRUE(m.ok()) << m.message();
    EXPECT_EQ(wire::type_of(*m), k == 0 ? msg::MessageType::Welcome : msg::MessageType::ObjectTableUpdate);
  }

  // Client -> host: a sealed Ack reaches the policy once; its replay, an altered copy and
  // a plain Ack are rejected and counted.
  msg::Ack ack;
  ack.last_batch_id = 7;
  const auto sealed_ack = peer.seal(ack);
  peer.send(sealed_ack);
  auto got = events_until(**host, [](const net::HostEvent& e) { return e.kind == net::HostEventKind::Message; });
  ASSERT_FALSE(got.empty());
  ASSERT_EQ(got.back().kind, net::HostEventKind::Message);
  ASSERT_TRUE(std::holds_alternative<msg::Ack>(got.back().message));
  EXPECT_EQ(std::get<msg::Ack>(got.back().message).last_batch_id, 7u);
  auto altered = peer.seal(ack);
  altered[net::kSealedHeaderBytes] ^= 0x40;
  peer.send(sealed_ack);
  peer.send(altered);
  peer.send(wire::encode(ack).value());
  ASSERT_TRUE([&] {
    const auto until = std::chrono::steady_clock::now() + 20s;
    while (std::chrono::steady_clock::now() < until) {
      peer.service(20ms);
      if ((*host)->counters().malformed >= 3) return true;
    }
    return false;
  }()) << (*host)->counters().last_rejection;
  for (const auto& e : (*host)->poll()) EXPECT_NE(e.kind, net::HostEventKind::Message) << "a rejected packet reached the policy";
  const auto hc = (*host)->counters();
  EXPECT_EQ(hc.malformed, 3u);
  EXPECT_EQ(hc.messages_received, 1u);
  EXPECT_EQ(hc.accepted, 1u);
}

TEST(SealedStream, AChallengeWithUnknownFlagsIsRefused) {
  msg::Challenge c;
  c.flags = 0x80;
  EXPECT_FALSE(wire::encode(c).ok()) << "the encoder never writes what the decoder refuses";
  c.flags = msg::kChallengeEncrypt;
  auto frame = wire::encode(c).value();
  ASSERT_TRUE(wire::decode(frame).ok());
  frame.back() |= 0x80;  // the flags byte ends the body
  auto bad = wire::decode(frame);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("flags"), std::string::npos) << bad.message();
}

TEST(SealedStream, EncryptionNeedsAToken) {
  net::NetHostConfig cfg;
  cfg.bind.port = 0;
  cfg.encrypt_stream = true;
  cfg.log = [](const std::string&) {};
  auto host = net::NetHost::start(cfg);
  ASSERT_FALSE(host.ok());
  EXPECT_NE(host.message().find("access token"), std::string::npos) << host.message();
}

}  // namespace
}  // namespace gauss
