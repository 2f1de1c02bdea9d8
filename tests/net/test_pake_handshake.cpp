// The CPace handshake (auth.h), driven directly and over loopback: the right secret agrees
// on keys both ways and each side proves it to the other; a wrong secret, a malformed CPace
// message, a point that does not decode and the identity are refused with a precise
// reason while the host keeps serving; the Challenge's flags cannot be altered on the
// path; a recorded transcript gives no test of a guess (the obvious computations of the
// client's tag from the token and the transcript do not match it, for the right token as
// for a wrong one); keys are fresh per connection; the pairing code connects and a wrong
// one is refused; a client with a secret refuses a host that cannot prove it.
#include <atomic>
#include <chrono>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <enet/enet.h>
#include <gtest/gtest.h>

#include "gauss/engine/wire.h"
#include "gauss/net/auth.h"
#include "gauss/net/client.h"
#include "gauss/net/cpace.h"
#include "gauss/net/host.h"
#include "old_token_keys.h"
#include "raw_peer.h"

namespace gauss {
namespace {

using namespace std::chrono_literals;
namespace cp = net::cpace;
using Bytes = std::vector<std::uint8_t>;

cp::Bytes text_bytes(std::string_view s) { return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()}; }

Bytes hello_frame(const std::string& name = "headset") {
  msg::Hello h;
  h.slot_capacity = 1000;
  h.client_name = name;
  return wire::encode(h).value();
}

const std::string kWrongTag =
    "the key confirmation does not match (a wrong access token or pairing code)";

TEST(PakeHandshake, TheRightSecretAgreesOnKeysAndBothSidesProveIt) {
  ASSERT_TRUE(net::auth_init().ok());
  const Bytes hello = hello_frame();
  net::HostHandshake host(net::AuthSecrets{"open-sesame", {}}, hello, msg::kChallengeEncrypt);
  ASSERT_EQ(host.challenge().offers.size(), 1u);
  EXPECT_EQ(host.challenge().offers[0].secret, msg::AuthSecret::AccessToken);
  EXPECT_EQ(host.challenge_frame(), wire::encode(host.challenge()).value());
  auto answer = net::answer_challenge("open-sesame", host.challenge_frame(), hello);
  ASSERT_TRUE(answer.ok()) << answer.message();
  auto keys = host.verify(answer->proof);
  ASSERT_TRUE(keys.ok()) << keys.message();
  EXPECT_EQ(keys->host_to_client, answer->keys.host_to_client);
  EXPECT_EQ(keys->client_to_host, answer->keys.client_to_host);
  EXPECT_NE(keys->host_to_client, keys->client_to_host) << "one key per direction";
  EXPECT_TRUE(net::host_confirmed(answer->keys, msg::AuthConfirm{keys->host_tag}));
  EXPECT_FALSE(net::host_confirmed(answer->keys, msg::AuthConfirm{keys->client_tag})) << "the tags differ by side";
  // The secret is nowhere in what crossed the wire.
  for (const Bytes& f : {host.challenge_frame(), wire::encode(answer->proof).value()})
    EXPECT_EQ(std::string(f.begin(), f.end()).find("open-sesame"), std::string::npos);
}

TEST(PakeHandshake, AWrongSecretIsRefused) {
  ASSERT_TRUE(net::auth_init().ok());
  const Bytes hello = hello_frame();
  net::HostHandshake host(net::AuthSecrets{"open-sesame", {}}, hello, 0);
  for (const char* guess : {"open-sesamE", "", "open-sesame "}) {
    auto answer = net::answer_challenge(guess, host.challenge_frame(), hello);
    ASSERT_TRUE(answer.ok()) << answer.message();
    auto keys = host.verify(answer->proof);
    ASSERT_FALSE(keys.ok()) << guess;
    EXPECT_EQ(keys.message(), kWrongTag);
  }
}

// The right token with another Hello (CI) or another nonce (sid) fails: a proof is bound
// to its connection.
TEST(PakeHandshake, AProofIsBoundToItsHelloAndNonce) {
  ASSERT_TRUE(net::auth_init().ok());
  const Bytes hello = hello_frame();
  net::HostHandshake host(net::AuthSecrets{"t0ken-t0ken", {}}, hello, 0);
  auto other_hello = net::answer_challenge("t0ken-t0ken", host.challenge_frame(), hello_frame("another"));
  ASSERT_TRUE(other_hello.ok());
  EXPECT_FALSE(host.verify(other_hello->proof).ok());
  net::HostHandshake second(net::AuthSecrets{"t0ken-t0ken", {}}, hello, 0);
  EXPECT_NE(second.challenge().nonce, host.challenge().nonce) << "fresh nonces";
  auto for_first = net::answer_challenge("t0ken-t0ken", host.challenge_frame(), hello);
  ASSERT_TRUE(for_first.ok());
  EXPECT_TRUE(host.verify(for_first->proof).ok());
  EXPECT_FALSE(second.verify(for_first->proof).ok()) << "a proof answers one connection only";
}

// A man in the middle who strips kChallengeEncrypt (or drops an offer) changes the
// Challenge's bytes, which both sides' keys depend on: the host refuses the proof.
TEST(PakeHandshake, TheChallengeCannotBeAlteredOnThePath) {
  ASSERT_TRUE(net::auth_init().ok());
  const Bytes hello = hello_frame();
  net::HostHandshake host(net::AuthSecrets{"open-sesame", "k3f9-x2ab"}, hello, msg::kChallengeEncrypt);
  msg::Challenge stripped = host.challenge();
  stripped.flags = 0;
  auto a = net::answer_challenge("open-sesame", wire::encode(stripped).value(), hello);
  ASSERT_TRUE(a.ok()) << a.message();
  EXPECT_EQ(host.verify(a->proof).message(), kWrongTag);
  msg::Challenge one_offer = host.challenge();
  one_offer.offers.pop_back();
  auto b = net::answer_challenge("open-sesame", wire::encode(one_offer).value(), hello);
  ASSERT_TRUE(b.ok()) << b.message();
  EXPECT_EQ(host.verify(b->proof).message(), kWrongTag);
  auto honest = net::answer_challenge("open-sesame", host.challenge_frame(), hello);
  ASSERT_TRUE(honest.ok());
  EXPECT_TRUE(host.verify(honest->proof).ok());
}

// What a hostile client may put in its proof, refused with what was wrong with it (never
// anything about the secret).
TEST(PakeHandshake, MalformedCPaceMessagesAreRefusedWithAPreciseReason) {
  ASSERT_TRUE(net::auth_init().ok());
  const Bytes hello = hello_frame();
  net::HostHandshake host(net::AuthSecrets{"open-sesame", {}}, hello, 0);
  auto honest = net::answer_challenge("open-sesame", host.challenge_frame(), hello);
  ASSERT_TRUE(honest.ok());
  msg::AuthProof identity = honest->proof;
  std::fill(identity.pake.begin() + 1, identity.pake.end() - 1, std::uint8_t{0});
  EXPECT_EQ(host.verify(identity).message(), "the client's CPace point is the identity");
  msg::AuthProof undecodable = honest->proof;
  std::fill(undecodable.pake.begin() + 1, undecodable.pake.end() - 1, std::uint8_t{0xFF});
  EXPECT_EQ(host.verify(undecodable).message(), "the client's CPace point does not decode to a ristretto255 element");
  msg::AuthProof not_offered = honest->proof;
  not_offered.secret = msg::AuthSecret::PairingCode;
  EXPECT_EQ(host.verify(not_offered).message(), "the proof answers a secret this host did not offer");
  EXPECT_TRUE(host.verify(honest->proof).ok()) << "refusals leave the handshake usable: the honest proof still passes";

  // Framing and lengths are the codec's: each names the field and the byte.
  const Bytes frame = wire::encode(honest->proof).value();
  auto expect_refused = [](Bytes f, const std::string& says) {
    auto d = wire::decode(f);
    ASSERT_FALSE(d.ok());
    EXPECT_NE(d.message().find(says), std::string::npos) << d.message();
  };
  Bytes bad_len = frame;
  bad_len[wire::kHeaderBytes + 1] = 31;  // the point's length byte
  expect_refused(bad_len, "AuthProof: field 'pake' at byte 1: the point's length byte is 31, must be 32");
  Bytes bad_ad = frame;
  bad_ad[wire::kHeaderBytes + 1 + msg::kPakeMessageBytes - 1] = 1;
  expect_refused(bad_ad, "AuthProof: field 'pake' at byte 34: the associated data's length byte is 1, must be 0");
  Bytes bad_secret = frame;
  bad_secret[wire::kHeaderBytes] = 9;
  expect_refused(bad_secret, "AuthProof: field 'secret' at byte 0: unknown secret 9");
  // One byte short and one byte over (the header's length kept honest).
  for (int delta : {-1, +1}) {
    Bytes f = frame;
    if (delta < 0) f.pop_back();
    else f.push_back(0);
    const auto body = static_cast<std::uint32_t>(f.size() - wire::kHeaderBytes);
    for (int i = 0; i < 4; ++i) f[4 + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(body >> (8 * i));
    expect_refused(f, delta < 0 ? "field 'tag'" : "trailing bytes");
  }
  // The Challenge's offers: none, too many, twice the same secret.
  msg::Challenge c = host.challenge();
  c.offers.clear();
  EXPECT_NE(wire::encode(c).message().find("0 offers"), std::string::npos);
  c = host.challenge();
  c.offers.push_back(c.offers[0]);
  EXPECT_NE(wire::encode(c).message().find("offered twice"), std::string::npos);
  Bytes three = host.challenge_frame();
  three[wire::kHeaderBytes + msg::kAuthNonceBytes + 1] = 3;
  expect_refused(three, "Challenge: field 'offers' at byte 33: 3 offers, must be 1 to 2");
  // A client given a bad host point refuses it the same way.
  msg::Challenge bad_host = host.challenge();
  std::fill(bad_host.offers[0].pake.begin() + 1, bad_host.offers[0].pake.end() - 1, std::uint8_t{0});
  auto a = net::answer_challenge("open-sesame", wire::encode(bad_host).value(), hello);
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.message(), "the host's CPace point is the identity");
}

// What an observer with the token can compute from a recorded handshake does not
// reproduce the client's tag: the tag needs K = Y_host^y_client (or Y_client^y_host), and
// the scalars never leave the two ends. So the transcript gives no test of a guess: the
// right token fails every attempt exactly like a wrong one.
TEST(PakeHandshake, TheTranscriptGivesNoOfflineTestOfAGuess) {
  ASSERT_TRUE(net::auth_init().ok());
  const std::string token = "open-sesame";
  const Bytes hello = hello_frame();
  net::HostHandshake host(net::AuthSecrets{token, {}}, hello, msg::kChallengeEncrypt);
  auto answer = net::answer_challenge(token, host.challenge_frame(), hello);
  ASSERT_TRUE(answer.ok());
  ASSERT_TRUE(host.verify(answer->proof).ok());
  // The recording: the Hello, the Challenge and the proof, as bytes and decoded.
  const msg::Challenge& c = host.challenge();
  const msg::AuthProof& p = answer->proof;
  const Bytes msg_a(c.offers[0].pake.begin(), c.offers[0].pake.end());
  const Bytes msg_b(p.pake.begin(), p.pake.end());
  const auto point_of = [](const Bytes& m) {
    auto parsed = cp::parse_message(m);
    EXPECT_TRUE(parsed.ok());
    return parsed.ok() ? parsed->y_public : cp::Point{};
  };
  const cp::Point y_a = point_of(msg_a), y_b = point_of(msg_b);
  for (const std::string& guess : {token, std::string("open-sesamf")}) {
    const cp::Point g = cp::calculate_generator(text_bytes(guess), hello, c.nonce);
    std::vector<std::pair<std::string, msg::AuthTag>> attempts;
    // Version 2's proof from the token and the public bytes.
    attempts.push_back({"version 2's proof", test::old_auth_proof(guess, c.nonce, hello)});
    // The key schedule over an ISK whose K is something public.
    const std::vector<std::pair<std::string, cp::Point>> public_ks = {
        {"K = the generator", g}, {"K = the host's point", y_a}, {"K = the client's point", y_b}};
    for (const auto& [name, k] : public_ks) {
      for (bool swapped : {false, true}) {
        const cp::Isk isk = swapped ? cp::isk_initiator_responder(c.nonce, k, msg_b, msg_a)
                                    : cp::isk_initiator_responder(c.nonce, k, msg_a, msg_b);
        attempts.push_back({name + (swapped ? ", messages swapped" : ""),
                            net::derive_session_keys(isk, hello, host.challenge_frame(), p.secret).client_tag});
      }
    }
    // Running the protocol again as the client, with a new scalar.
    auto again = net::answer_challenge(guess, host.challenge_frame(), hello);
    ASSERT_TRUE(again.ok());
    attempts.push_back({"a fresh client run", again->proof.tag});
    for (const auto& [what, tag] : attempts)
      EXPECT_NE(tag, p.tag) << what << " with guess '" << guess << "' reproduces the recorded tag";
  }
}

TEST(PakeHandshake, KeysAreFreshPerConnection) {
  ASSERT_TRUE(net::auth_init().ok());
  const Bytes hello = hello_frame();
  std::vector<net::StreamKey> seen;
  for (int k = 0; k < 2; ++k) {
    net::HostHandshake host(net::AuthSecrets{"open-sesame", {}}, hello, msg::kChallengeEncrypt);
    auto answer = net::answer_challenge("open-sesame", host.challenge_frame(), hello);
    ASSERT_TRUE(answer.ok());
    seen.push_back(answer->keys.host_to_client);
  }
  EXPECT_NE(seen[0], seen[1]);
  // Even the same nonce (a host replaying its Challenge) gives new keys: the client's
  // scalar is fresh.
  net::HostHandshake host(net::AuthSecrets{"open-sesame", {}}, hello, 0);
  auto a1 = net::answer_challenge("open-sesame", host.challenge_frame(), hello);
  auto a2 = net::answer_challenge("open-sesame", host.challenge_frame(), hello);
  ASSERT_TRUE(a1.ok() && a2.ok());
  EXPECT_NE(a1->keys.host_to_client, a2->keys.host_to_client);
  EXPECT_TRUE(host.verify(a1->proof).ok() && host.verify(a2->proof).ok());
}

TEST(PairingCode, GeneratedCodesAreEightTypeableSymbols) {
  ASSERT_TRUE(net::auth_init().ok());
  std::string previous;
  for (int k = 0; k < 50; ++k) {
    const std::string code = net::generate_pairing_code();
    ASSERT_EQ(code.size(), 9u) << code;
    EXPECT_EQ(code[4], '-') << code;
    auto canonical = net::canonical_pairing_code(code);
    ASSERT_TRUE(canonical.has_value()) << code;
    EXPECT_EQ(*canonical, code.substr(0, 4) + code.substr(5)) << code;
    EXPECT_NE(code, previous);
    previous = code;
  }
  EXPECT_EQ(net::canonical_pairing_code("K3F9-X2AB").value_or(""), "k3f9x2ab");
  EXPECT_EQ(net::canonical_pairing_code(" k3f9 x2ab ").value_or(""), "k3f9x2ab");
  EXPECT_EQ(net::canonical_pairing_code("OILO-x2ab").value_or(""), "0110x2ab") << "Crockford's readings";
  EXPECT_FALSE(net::canonical_pairing_code("k3f9-x2a").has_value()) << "7 symbols";
  EXPECT_FALSE(net::canonical_pairing_code("k3f9-x2abc").has_value()) << "9 symbols";
  EXPECT_FALSE(net::canonical_pairing_code("k3f9-x2au").has_value()) << "u is not a symbol";
  EXPECT_FALSE(net::canonical_pairing_code("").has_value());
  EXPECT_FALSE(net::weak_token_reason(net::generate_pairing_code()).has_value());
}

TEST(PairingCode, TheClientAnswersTheOfferItsSecretFits) {
  ASSERT_TRUE(net::auth_init().ok());
  const Bytes hello = hello_frame();
  net::HostHandshake host(net::AuthSecrets{"a-long-random-token-x", "k3f9-x2ab"}, hello, 0);
  ASSERT_EQ(host.challenge().offers.size(), 2u);
  auto by_code = net::answer_challenge("K3F9 X2AB", host.challenge_frame(), hello);
  ASSERT_TRUE(by_code.ok()) << by_code.message();
  EXPECT_EQ(by_code->proof.secret, msg::AuthSecret::PairingCode);
  EXPECT_TRUE(host.verify(by_code->proof).ok());
  auto by_token = net::answer_challenge("a-long-random-token-x", host.challenge_frame(), hello);
  ASSERT_TRUE(by_token.ok());
  EXPECT_EQ(by_token->proof.secret, msg::AuthSecret::AccessToken);
  EXPECT_TRUE(host.verify(by_token->proof).ok());
  auto wrong = net::answer_challenge("k3f9-x2ac", host.challenge_frame(), hello);
  ASSERT_TRUE(wrong.ok());
  EXPECT_EQ(host.verify(wrong->proof).message(), kWrongTag);
  // A host that offers only a code cannot be answered with something else.
  net::HostHandshake code_only(net::AuthSecrets{{}, "k3f9-x2ab"}, hello, 0);
  auto not_a_code = net::answer_challenge("a-long-random-token-x", code_only.challenge_frame(), hello);
  ASSERT_FALSE(not_a_code.ok());
  EXPECT_NE(not_a_code.message().find("pairing code"), std::string::npos) << not_a_code.message();
}

// ---- Over loopback ----------------------------------------------------------------

class Sink final : public net::ClientSink {
 public:
  void on_welcome(const msg::Welcome&) override {}
  void on_message(wire::Message&&) override {}
  void on_refused(const msg::Refuse& r) override {
    std::lock_guard lock(mu);
    refused = r;
  }
  void on_disconnected(const std::string&) override {}
  std::optional<msg::Refuse> refusal() {
    std::lock_guard lock(mu);
    return refused;
  }

 private:
  std::mutex mu;
  std::optional<msg::Refuse> refused;
};

net::NetHostConfig host_config(const std::string& token, const std::string& code = {}) {
  net::NetHostConfig c;
  c.bind.port = 0;
  c.access_token = token;
  c.pairing_code = code;
  c.admission.auth_backoff_initial = 0ms;  // several tries from 127.0.0.1 in a row
  c.admission.auth_backoff_max = 0ms;
  c.log = [](const std::string&) {};
  return c;
}

net::NetClientConfig client_config(std::uint16_t port, const std::string& secret) {
  net::NetClientConfig c;
  c.server = {"127.0.0.1", port};
  c.slot_capacity = 1000;
  c.name = "pake";
  c.access_token = secret;
  c.reconnect = false;
  c.log = [](const std::string&) {};
  return c;
}

// Welcomes every client that connects, until stopped (the policy's part).
class Welcomer {
 public:
  explicit Welcomer(net::NetHost& host) : host_(host), thread_([this] { run(); }) {}
  ~Welcomer() {
    stop_ = true;
    thread_.join();
  }

 private:
  void run() {
    while (!stop_) {
      host_.wait(20ms);
      for (const auto& e : host_.poll())
        if (e.kind == net::HostEventKind::Connected)
          (void)host_.send(e.client, msg::Welcome{msg::kProtocolVersion, host_.session_id(), e.client, e.hello.slot_capacity});
    }
  }
  net::NetHost& host_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

TEST(PakeLoopback, APairingCodeConnectsAndAWrongOneIsRefused) {
  auto host = net::NetHost::start(host_config(net::generate_access_token(), "k3f9-x2ab"));
  ASSERT_TRUE(host.ok()) << host.message();
  Welcomer welcomer(**host);
  Sink right, wrong;
  auto c1 = net::NetClient::start(client_config((*host)->port(), "K3F9-X2AB"), right);
  ASSERT_TRUE(c1.ok()) << c1.message();
  EXPECT_TRUE((*c1)->wait_for(net::ClientStatus::Connected, 20s)) << (*c1)->counters().last_rejection;
  auto c2 = net::NetClient::start(client_config((*host)->port(), "k3f9-x2ac"), wrong);
  ASSERT_TRUE(c2.ok());
  ASSERT_TRUE((*c2)->wait_for(net::ClientStatus::Refused, 20s));
  ASSERT_TRUE(wrong.refusal().has_value());
  EXPECT_EQ(wrong.refusal()->reason, msg::RefuseReason::BadToken);
  EXPECT_EQ(wrong.refusal()->detail, "authentication failed: " + kWrongTag);
  const auto hc = (*host)->counters();
  EXPECT_EQ(hc.accepted, 1u);
  EXPECT_EQ(hc.refused_token, 1u);
}

TEST(PakeLoopback, HostConfigRefusesABadPairingCode) {
  auto bad = net::NetHost::start(host_config("a-long-random-token-x", "k3f9"));
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("pairing code"), std::string::npos) << bad.message();
  auto ambiguous = net::NetHost::start(host_config("abcd-efgh", "k3f9-x2ab"));
  ASSERT_FALSE(ambiguous.ok()) << "a code-shaped token beside a code: a client could not tell which it holds";
}

// Hostile proofs over the wire: each is refused with its reason, counted as a failed
// proof, and the host goes on serving (an honest client gets in afterwards).
TEST(PakeLoopback, MalformedProofsAreRefusedPreciselyAndTheHostKeepsServing) {
  const std::string token = "open-sesame";
  auto host = net::NetHost::start(host_config(token));
  ASSERT_TRUE(host.ok()) << host.message();
  const Bytes hello = hello_frame("hostile");
  struct Case {
    std::function<Bytes(const net::ClientAnswer&)> proof;
    std::string refusal;
  };
  const std::vector<Case> cases = {
      {[](const net::ClientAnswer& a) {
         msg::AuthProof p = a.proof;
         std::fill(p.pake.begin() + 1, p.pake.end() - 1, std::uint8_t{0});
         return wire::encode(p).value();
       },
       "authentication failed: the client's CPace point is the identity"},
      {[](const net::ClientAnswer& a) {
         msg::AuthProof p = a.proof;
         std::fill(p.pake.begin() + 1, p.pake.end() - 1, std::uint8_t{0xFF});
         return wire::encode(p).value();
       },
       "authentication failed: the client's CPace point does not decode to a ristretto255 element"},
      {[](const net::ClientAnswer& a) {
         Bytes f = wire::encode(a.proof).value();
         f[wire::kHeaderBytes + 1] = 33;
         return f;
       },
       "authentication failed: AuthProof: field 'pake' at byte 1: the point's length byte is 33, must be 32"},
      {[](const net::ClientAnswer& a) {
         Bytes f = wire::encode(a.proof).value();
         f.resize(wire::kHeaderBytes + 20);
         f[4] = 20;
         return f;
       },
       "authentication failed: AuthProof: field 'pake' at byte 1: needs 34 bytes, 19 left"},
      {[](const net::ClientAnswer&) { return wire::encode(msg::Ack{}).value(); },
       "authentication failed: expected AuthProof, got Ack"},
  };
  for (const auto& c : cases) {
    test::RawPeer p((*host)->port());
    ASSERT_TRUE(p.connected());
    p.send(hello);
    auto challenge = p.receive_packet();
    ASSERT_TRUE(challenge.has_value());
    auto answer = net::answer_challenge(token, *challenge, hello);
    ASSERT_TRUE(answer.ok()) << answer.message();
    p.send(c.proof(*answer));
    auto r = p.refuse_then_disconnect();
    ASSERT_TRUE(r.has_value()) << c.refusal;
    EXPECT_EQ(r->reason, msg::RefuseReason::BadToken);
    EXPECT_EQ(r->detail, c.refusal);
  }
  EXPECT_EQ((*host)->counters().refused_token, cases.size()) << "each counted as a failed proof";
  Welcomer welcomer(**host);
  Sink sink;
  auto honest = net::NetClient::start(client_config((*host)->port(), token), sink);
  ASSERT_TRUE(honest.ok());
  EXPECT_TRUE((*honest)->wait_for(net::ClientStatus::Connected, 20s)) << (*honest)->counters().last_rejection;
  EXPECT_EQ((*host)->counters().accepted, 1u);
}

// A client holding a secret talks only to a host that proves it knows it: a host without
// a token (it welcomes at once) and a rogue host that guesses (its AuthConfirm cannot be
// right) are both refused by the client, which does not retry.
TEST(PakeLoopback, AClientWithASecretRefusesAHostThatCannotProveIt) {
  {
    auto open_host = net::NetHost::start(host_config({}));
    ASSERT_TRUE(open_host.ok());
    Welcomer welcomer(**open_host);
    Sink sink;
    auto c = net::NetClient::start(client_config((*open_host)->port(), "open-sesame"), sink);
    ASSERT_TRUE(c.ok());
    ASSERT_TRUE((*c)->wait_for(net::ClientStatus::Refused, 20s));
    ASSERT_TRUE(sink.refusal().has_value());
    EXPECT_NE(sink.refusal()->detail.find("sent Welcome without proving it knows the access token"), std::string::npos)
        << sink.refusal()->detail;
  }
  enet_initialize();
  ENetHost* rogue = test::rogue_host_on_loopback();
  ASSERT_NE(rogue, nullptr);
  Sink sink;
  auto c = net::NetClient::start(client_config(rogue->address.port, "open-sesame"), sink);
  ASSERT_TRUE(c.ok());
  std::unique_ptr<net::HostHandshake> guess;
  bool proof_checked = false;
  auto send = [&](ENetPeer* peer, const Bytes& f) {
    ENetPacket* p = enet_packet_create(f.data(), f.size(), ENET_PACKET_FLAG_RELIABLE);
    if (enet_peer_send(peer, 0, p) != 0) enet_packet_destroy(p);
    enet_host_flush(rogue);
  };
  ASSERT_TRUE(test::wait_until([&] {
    ENetEvent ev;
    while (enet_host_service(rogue, &ev, 0) > 0) {
      if (ev.type != ENET_EVENT_TYPE_RECEIVE) continue;
      const Bytes packet(ev.packet->data, ev.packet->data + ev.packet->dataLength);
      enet_packet_destroy(ev.packet);
      if (!guess) {  // the Hello: challenge it with a guessed token
        guess = std::make_unique<net::HostHandshake>(net::AuthSecrets{"open-sesamf", {}}, packet, 0);
        send(ev.peer, guess->challenge_frame());
      } else if (!proof_checked) {  // the proof: it cannot verify, so the rogue makes up a tag
        auto proof = wire::decode(packet);
        EXPECT_TRUE(proof.ok() && std::holds_alternative<msg::AuthProof>(*proof));
        if (proof.ok() && std::holds_alternative<msg::AuthProof>(*proof)) {
          EXPECT_FALSE(guess->verify(std::get<msg::AuthProof>(*proof)).ok());
        }
        proof_checked = true;
        msg::AuthConfirm made_up;
        made_up.tag.fill(0x42);
        send(ev.peer, wire::encode(made_up).value());
        send(ev.peer, wire::encode(msg::Welcome{msg::kProtocolVersion, 1, 1, 1000}).value());
      }
    }
    return (*c)->status() == net::ClientStatus::Refused;
  }));
  EXPECT_TRUE(proof_checked);
  ASSERT_TRUE(sink.refusal().has_value());
  EXPECT_NE(sink.refusal()->detail.find("could not prove it knows the access token"), std::string::npos)
      << sink.refusal()->detail;
  EXPECT_EQ((*c)->counters().welcomes, 0u);
  c->reset();
  enet_host_destroy(rogue);
  enet_deinitialize();
}

}  // namespace
}  // namespace gauss
