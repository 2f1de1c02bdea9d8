// Sealed streams (NetHostConfig::encrypt_stream, stream_cipher.h): the cipher's contract
// (round trip, per-key and per-direction, replays and alterations refused, reordering
// within the window accepted, a forgery spends no counter), and on a live loopback
// connection: everything after the handshake travels sealed both ways, nothing the host
// sends reads as a frame on the wire, a replayed, altered or plain packet from the client
// is rejected and counted without reaching the policy, and a recorded session stays
// sealed from someone who has the recording and the token (forward secrecy).
#include <chrono>
#include <string>
#include <thread>

#include <enet/enet.h>
#include <gtest/gtest.h>

#include "gauss/engine/wire.h"
#include "gauss/net/auth.h"
#include "gauss/net/host.h"
#include "gauss/net/stream_cipher.h"
#include "old_token_keys.h"
#include "raw_peer.h"
#include "text_file.h"

namespace gauss {
namespace {

using namespace std::chrono_literals;

// A key as a handshake would give it (the cipher does not care where it came from;
// test_pake_handshake.cpp checks the keys themselves).
net::StreamKey key_of(std::uint8_t seed) {
  EXPECT_TRUE(net::auth_init().ok());
  net::StreamKey k{};
  for (std::size_t i = 0; i < k.size(); ++i) k[i] = static_cast<std::uint8_t>(seed + 13 * i);
  return k;
}

TEST(StreamCipher, RoundTripsAndTheWireCarriesNoPlaintext) {
  const auto key = key_of(1);
  net::StreamCipher seal(key, net::StreamDirection::HostToClient);
  net::StreamCipher open(key, net::StreamDirection::HostToClient);
  const auto frame = test::bytes_of("the chair is in the corner");
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

TEST(StreamCipher, APacketOpensOnlyUnderItsKeyAndDirection) {
  const auto key = key_of(1);
  net::StreamCipher seal(key, net::StreamDirection::HostToClient);
  const auto packet = seal.seal(test::bytes_of("frame"));
  auto other_key = key;
  other_key[31] ^= 1;
  net::StreamCipher wrong_key(other_key, net::StreamDirection::HostToClient);
  net::StreamCipher wrong_way(key, net::StreamDirection::ClientToHost);
  EXPECT_FALSE(wrong_key.open(packet).ok());
  EXPECT_FALSE(wrong_way.open(packet).ok()) << "a packet cannot be reflected back to its sender";
  net::StreamCipher right(key, net::StreamDirection::HostToClient);
  EXPECT_TRUE(right.open(packet).ok());
}

TEST(StreamCipher, ReplaysAndAlterationsAreRefusedReorderingIsNot) {
  const auto key = key_of(2);
  net::StreamCipher seal(key, net::StreamDirection::ClientToHost);
  net::StreamCipher open(key, net::StreamDirection::ClientToHost);
  std::vector<std::vector<std::uint8_t>> packets;
  for (int i = 0; i < 6; ++i) packets.push_back(seal.seal(test::bytes_of("frame " + std::to_string(i))));
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
  for (std::size_t i = 0; i < net::kReplayWindow + 1; ++i) ASSERT_TRUE(open.open(seal.seal(test::bytes_of("x"))).ok());
  EXPECT_FALSE(open.open(packets[5]).ok()) << "more than the window behind the newest";
}

// A raw ENet client speaking the sealed protocol by hand, so the test can replay, alter
// and send plain packets after the handshake. It records the handshake's packets as an
// observer on the path would see them.
class SealedPeer {
 public:
  SealedPeer(std::uint16_t port, const std::string& token) : raw_(port), token_(token) {}

  // Hello, Challenge (must ask for a sealed stream), proof, the host's confirmation;
  // then the keys.
  bool handshake() {
    if (!raw_.connected()) return false;
    msg::Hello hello;
    hello.slot_capacity = 100;
    hello.client_name = "sealed";
    hello_frame = wire::encode(hello).value();
    raw_.send(hello_frame);
    auto challenge = raw_.receive_packet();
    if (!challenge) return false;
    challenge_frame = *challenge;
    auto m = wire::decode(challenge_frame);
    if (!m || !std::holds_alternative<msg::Challenge>(*m)) return false;
    if (!(std::get<msg::Challenge>(*m).flags & msg::kChallengeEncrypt)) return false;
    auto answer = net::answer_challenge(token_, challenge_frame, hello_frame);
    if (!answer) return false;
    proof_frame = wire::encode(answer->proof).value();
    raw_.send(proof_frame);
    auto confirm_packet = raw_.receive_packet();
    if (!confirm_packet) return false;
    confirm_frame = *confirm_packet;
    auto confirm = wire::decode(confirm_frame);
    if (!confirm || !std::holds_alternative<msg::AuthConfirm>(*confirm) ||
        !net::host_confirmed(answer->keys, std::get<msg::AuthConfirm>(*confirm)))
      return false;
    sealer_ = std::make_unique<net::StreamCipher>(answer->keys.client_to_host, net::StreamDirection::ClientToHost);
    opener_ = std::make_unique<net::StreamCipher>(answer->keys.host_to_client, net::StreamDirection::HostToClient);
    return true;
  }
  std::vector<std::uint8_t> hello_frame, challenge_frame, proof_frame, confirm_frame;
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

// A host that requires `token` and seals its stream.
Expected<std::unique_ptr<net::NetHost>> start_sealed_host(const std::string& token) {
  net::NetHostConfig cfg;
  cfg.bind.port = 0;
  cfg.access_token = token;
  cfg.encrypt_stream = true;
  cfg.log = [](const std::string&) {};
  return net::NetHost::start(cfg);
}

// Runs `peer`'s handshake with `host`: the client id the host announces, or 0.
std::uint32_t connect_sealed(net::NetHost& host, SealedPeer& peer) {
  if (!peer.handshake()) return 0;
  auto connected = events_until(host, [](const net::HostEvent& e) { return e.kind == net::HostEventKind::Connected; });
  if (connected.empty() || connected.back().kind != net::HostEventKind::Connected) return 0;
  return connected.back().client;
}

TEST(SealedStream, ALiveConnectionIsSealedBothWaysAndRefusesReplays) {
  const std::string token = "private scene";
  auto host = start_sealed_host(token);
  ASSERT_TRUE(host.ok()) << host.message();
  SealedPeer peer((*host)->port(), token);
  const std::uint32_t id = connect_sealed(**host, peer);
  ASSERT_NE(id, 0u);

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

// Forward secrecy and no offline test, on a live connection: an observer records the
// whole handshake and the first sealed frames both ways, and later learns the token. None
// of what it can compute opens them: not the keys version 2 derived from the token and
// public bytes, not a fresh CPace run as the client (new scalar, the recorded Challenge),
// not a fresh run as the host (the recorded nonce and the client's recorded message, a
// new scalar), which the host's own check refuses too. The honest ends' keys did open
// them, and are gone with the connection.
TEST(SealedStream, ARecordedSessionStaysSealedEvenWithTheToken) {
  const std::string token = "private scene";
  auto host = start_sealed_host(token);
  ASSERT_TRUE(host.ok()) << host.message();
  SealedPeer peer((*host)->port(), token);
  const std::uint32_t id = connect_sealed(**host, peer);
  ASSERT_NE(id, 0u);
  ASSERT_TRUE((*host)->send(id, msg::Welcome{msg::kProtocolVersion, (*host)->session_id(), id, 100}).ok());
  std::vector<std::vector<std::uint8_t>> down;  // host -> client, as recorded
  auto welcome = peer.receive_packet();
  ASSERT_TRUE(welcome.has_value());
  ASSERT_TRUE(peer.open(*welcome).ok()) << "the honest client opens it";
  down.push_back(*welcome);
  msg::Ack ack;
  ack.last_batch_id = 3;
  const auto up = peer.seal(ack);  // client -> host, as recorded
  peer.send(up);
  ASSERT_FALSE(events_until(**host, [](const net::HostEvent& e) { return e.kind == net::HostEventKind::Message; }).empty());

  // The recording, and what the attacker derives from it with the token.
  const auto challenge = wire::decode(peer.challenge_frame);
  const auto proof = wire::decode(peer.proof_frame);
  ASSERT_TRUE(challenge.ok() && proof.ok());
  const auto& c = std::get<msg::Challenge>(*challenge);
  const auto& p = std::get<msg::AuthProof>(*proof);
  std::vector<std::pair<std::string, net::StreamKey>> candidates;
  for (std::uint8_t d : {1, 2})
    candidates.push_back({"version 2's token key, direction " + std::to_string(d),
                          test::old_stream_key(token, c.nonce, peer.hello_frame, d)});
  auto as_client = net::answer_challenge(token, peer.challenge_frame, peer.hello_frame);
  ASSERT_TRUE(as_client.ok()) << as_client.message();
  EXPECT_NE(as_client->proof.tag, p.tag) << "a fresh run does not reproduce the recorded proof";
  candidates.push_back({"a fresh client run, host to client", as_client->keys.host_to_client});
  candidates.push_back({"a fresh client run, client to host", as_client->keys.client_to_host});
  net::HostHandshake as_host(net::AuthSecrets{token, {}}, peer.hello_frame, c.flags, &c.nonce);
  auto verified = as_host.verify(p);
  EXPECT_FALSE(verified.ok()) << "a fresh host scalar does not match the recorded proof";
  const auto party = net::cpace::start(std::span(reinterpret_cast<const std::uint8_t*>(token.data()), token.size()),
                                       peer.hello_frame, c.nonce, {});
  auto isk = net::cpace::finish_initiator(party, c.nonce, p.pake);
  ASSERT_TRUE(isk.ok()) << isk.message();
  const auto fresh_host = net::derive_session_keys(*isk, peer.hello_frame, peer.challenge_frame, p.secret);
  candidates.push_back({"a fresh host run, host to client", fresh_host.host_to_client});
  candidates.push_back({"a fresh host run, client to host", fresh_host.client_to_host});
  for (const auto& [what, key] : candidates) {
    for (auto dir : {net::StreamDirection::HostToClient, net::StreamDirection::ClientToHost}) {
      net::StreamCipher opener(key, dir);
      for (const auto& packet : down) EXPECT_FALSE(opener.open(packet).ok()) << what << " opened a recorded frame";
      EXPECT_FALSE(opener.open(up).ok()) << what << " opened a recorded frame";
    }
  }
}

TEST(SealedStream, AChallengeWithUnknownFlagsIsRefused) {
  msg::Challenge c;
  msg::AuthOffer offer;
  offer.pake.front() = static_cast<std::uint8_t>(msg::kPakePointBytes);
  c.offers.push_back(offer);
  c.flags = 0x80;
  EXPECT_FALSE(wire::encode(c).ok()) << "the encoder never writes what the decoder refuses";
  c.flags = msg::kChallengeEncrypt;
  auto frame = wire::encode(c).value();
  ASSERT_TRUE(wire::decode(frame).ok());
  frame[wire::kHeaderBytes + msg::kAuthNonceBytes] |= 0x80;  // the flags byte follows the nonce
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
